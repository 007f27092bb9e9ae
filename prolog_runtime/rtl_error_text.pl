:- module(rtl_error_text,
          [ rtl_error_text/2,           % +Error, -Text
            rtl_term_text/2             % +Term, -Text
          ]).

/** <module> The one printer of errors: a line of text for any error term, never interpreted

Every error the runtime reports (an event that failed, a refused goal, a query that raised,
an Engine call, a service call) becomes text here, and only here. The term may come from
untrusted code (`throw(Ball)` in a query, a condition or an added rule), so it is data: it is
never given to the message system ('$messages':translate_message//1, print_message/2,
message_to_string/2), which runs hooks and `format/2` directives (`~@` calls a goal) named
by the term itself. Parts of the term are written with writeq under limits instead
(rtl_term_text/2: max_depth/1 cuts deep terms and long lists), and the line is cut at
max_line_length/1 characters: an error holding a 300,000-element list or a 10 MB atom gives
a short line.

Known forms get friendly text built from those parts: the ISO error terms (`type_error`,
`existence_error(procedure, PI)`, ... with SWI-Prolog's wording), and the runtime's own
errors (the step limit, the query time limit, a refused goal and the others its modules
declare with runtime_error_text/2). Anything else is `Unknown error term: F` or `Unhandled
exception: B`, F and B written as above.
*/

:- use_module(library(lists)).

%!  runtime_error_text(+Formal, -Text:string) is semidet.
%
%   Multifile: the text of a runtime error `error(Formal, _)`, defined by the runtime module
%   that raises it (rtl_sandbox.pl for rtl_unsafe/3, ...). A clause writes the parts of
%   Formal that are not its own with rtl_term_text/2. Only runtime modules add clauses:
%   untrusted code may not change any predicate outside its own temporary module.

:- multifile runtime_error_text/2.

max_depth(8).
max_line_length(2000).

%!  rtl_error_text(+Error, -Text:string) is det.
%
%   One line (no newline in it) of at most 2,000 characters for Error, a ball of any form.

rtl_error_text(Error, Text) :-
    (   catch(error_text(Error, Text0), _, fail)
    ->  true
    ;   rtl_term_text(Error, Body),
        string_concat("Unhandled exception: ", Body, Text0)
    ),
    one_line(Text0, Text).

%!  rtl_term_text(+Term, -Text:string) is det.
%
%   Term written as writeq/1 writes it, at most 8 levels deep (a longer list shows its
%   first items and `|...`), without portray hooks or attributes, at most 2,000 characters.

rtl_term_text(Term, Text) :-
    max_depth(Depth),
    with_output_to(string(Text0),
                   write_term(Term, [ quoted(true), max_depth(Depth), portray(false),
                                      attributes(ignore), cycles(true), numbervars(true) ])),
    one_line(Text0, Text).

one_line(Text0, Text) :-
    split_string(Text0, "\n\r", "", Parts),
    atomic_list_concat(Parts, ' ', Line),
    max_line_length(Max),
    (   atom_length(Line, L), L > Max
    ->  Keep is Max - 3,
        sub_atom(Line, 0, Keep, _, Head),
        atom_concat(Head, '...', Cut),
        atom_string(Cut, Text)
    ;   atom_string(Line, Text)
    ).

error_text(Error, _) :-
    var(Error), !,
    fail.
error_text(time_limit_exceeded, "no answer within the time limit") :- !.
error_text(error(resource_error(stack), Context), Text) :-
    is_dict(Context),
    get_dict(stack_limit, Context, KB),
    integer(KB), !,
    GB is KB / 1048576,
    format(string(Text), "Stack limit (~1fGb) exceeded", [GB]).
error_text(error(Formal, Context), Text) :- !,
    nonvar(Formal),
    (   runtime_error_text(Formal, Text0)
    ->  true
    ;   iso_text(Formal, Text0)
    ->  true
    ;   rtl_term_text(Formal, F),
        string_concat("Unknown error term: ", F, Text0)
    ),
    with_context(Context, Text0, Text).
error_text(Ball, Text) :-
    rtl_term_text(Ball, B),
    string_concat("Unhandled exception: ", B, Text).

runtime_error_text(rtl_step_limit(Max), Text) :-
    integer(Max),
    format(string(Text), "more than ~D steps (--max-steps)", [Max]).

% The ISO error terms, in SWI-Prolog's words.
iso_text(instantiation_error, "Arguments are not sufficiently instantiated").
iso_text(uninstantiation_error(V), Text) :-
    format_parts("Uninstantiated argument expected, found ~s", [V], Text).
iso_text(type_error(Type, Value), Text) :-
    rtl_term_text(Type, T),
    rtl_term_text(Value, V),
    value_kind(Value, Kind),
    format(string(Text), "Type error: `~s' expected, found `~s' (~w)", [T, V, Kind]).
iso_text(domain_error(Domain, Value), Text) :-
    format_parts("Domain error: `~s' expected, found `~s'", [Domain, Value], Text).
iso_text(existence_error(procedure, PI), Text) :-
    format_parts("Unknown procedure: ~s", [PI], Text).
iso_text(existence_error(Type, Value), Text) :-
    format_parts("~s `~s' does not exist", [Type, Value], Text).
iso_text(existence_error(Type, Value, In), Text) :-
    format_parts("~s `~s' does not exist in ~s", [Type, Value, In], Text).
iso_text(permission_error(Action, Type, Culprit), Text) :-
    format_parts("No permission to ~s ~s `~s'", [Action, Type, Culprit], Text).
iso_text(representation_error(What), Text) :-
    format_parts("Cannot represent due to `~s'", [What], Text).
iso_text(evaluation_error(What), Text) :-
    format_parts("Arithmetic: evaluation error: ~s", [What], Text).
iso_text(resource_error(stack), "Stack limit exceeded") :- !.
iso_text(resource_error(What), Text) :-
    format_parts("Not enough resources: ~s", [What], Text).
iso_text(syntax_error(What), Text) :-
    (   text(What) -> format(string(Text), "Syntax error: ~w", [What])
    ;   format_parts("Syntax error: ~s", [What], Text)
    ).

text(T) :- ( atom(T) ; string(T) ), !.

format_parts(Format, Terms, Text) :-
    maplist(rtl_term_text, Terms, Parts),
    format(string(Text), Format, Parts).

value_kind(V, 'a var') :- var(V), !.
value_kind(V, 'an integer') :- integer(V), !.
value_kind(V, 'a float') :- float(V), !.
value_kind(V, 'a number') :- number(V), !.
value_kind(V, 'an atom') :- atom(V), !.
value_kind(V, 'a string') :- string(V), !.
value_kind([_|_], 'a list') :- !.
value_kind(_, 'a compound').

% The context of `error(Formal, Context)`: the predicate that raised it first, its message
% after; a syntax error in a string shows where.
with_context(Context, Text0, Text) :-
    (   nonvar(Context), Context = context(Pred, Message)
    ->  (   nonvar(Pred), Pred \== []
        ->  rtl_term_text(Pred, P),
            format(string(Text1), "~s: ~s", [P, Text0])
        ;   Text1 = Text0
        ),
        (   nonvar(Message), text(Message)
        ->  format(string(Text), "~s (~w)", [Text1, Message])
        ;   nonvar(Message)
        ->  rtl_term_text(Message, M),
            format(string(Text), "~s (~s)", [Text1, M])
        ;   Text = Text1
        )
    ;   nonvar(Context), Context = string(String, CharNo), text(String), integer(CharNo)
    ->  format(string(Text), "~s (at character ~w)", [Text0, CharNo])
    ;   Text = Text0
    ).
