% Quoted atoms that span lines (a newline inside the quotes is part of the atom).
:- dynamic note/2, tag/2.
note(1, 'first line
second line').
note(2, 'one line').
tag(1, 'multi
line
tag').
tagged(N, T, Text) :- note(N, Text), tag(N, T).
