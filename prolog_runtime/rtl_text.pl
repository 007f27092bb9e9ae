:- module(rtl_text,
          [ rtl_read_text/4,            % +Text, -Term, -Bindings, +Options
            rtl_read_event/2,           % +Text, -Event
            rtl_read_ground/2,          % +Text, -Term
            rtl_ground_canonical/2,     % +Text, -Canonical
            rtl_write_readable/2        % +Stream, +Term
          ]).

/** <module> Reading untrusted text as one term

Text from outside the program (an event, a goal, a rule label, a flag value from Python or
a service) is data: it is read with read_term/3 from a string, never pasted into program
text. The whole text must be one term, optionally ended by a full stop; anything after it
(`"a(1). halt"`) is a syntax error, as are an empty text and a variable where a term is
needed. Syntax errors are raised as `error(syntax_error(What), string(Text, CharNo))`, as
term_string/3 raises them.
*/

%!  rtl_read_text(+Text, -Term, -Bindings, +Options) is det.
%
%   Read Text (a string or atom) as exactly one term. Bindings are its `Name = Var` pairs.
%   Options are passed to read_term/3 (e.g. `module(M)` for the operators of a program).

rtl_read_text(Text, Term, Bindings, Options) :-
    must_be(text, Text),
    (   split_string(Text, "", " \t\r\n", [""])
    ->  syntax_error_at(empty_text, Text, 0)
    ;   true
    ),
    catch(read_term_from_atom(Text, Term0,
                              [ variable_names(Bindings0), subterm_positions(Pos),
                                syntax_errors(error) | Options ]),
          error(syntax_error(What), Context),
          string_error(What, Context, Text)),
    arg(2, Pos, End),
    sub_string(Text, End, _, 0, Rest0),
    split_string(Rest0, "", " \t\r\n", [Rest1]),
    (   sub_string(Rest1, 0, 1, _, ".")
    ->  sub_string(Rest1, 1, _, 0, Rest)
    ;   Rest = Rest1
    ),
    (   ( Rest == "" ; only_layout(Rest) )      % (the common case needs no second read)
    ->  Term = Term0,
        Bindings = Bindings0
    ;   syntax_error_at(end_of_clause_expected, Text, End)
    ).

%   Nothing but white space and comments.
only_layout(Rest) :-
    setup_call_cleanup(open_string(Rest, In),
                       catch(read_term(In, T, []), error(syntax_error(_), _), T = '$bad'),
                       close(In)),
    T == end_of_file.

string_error(What, Context, Text) :-
    (   Context = stream(_, _, _, CharNo), integer(CharNo)
    ->  true
    ;   Context = file(_, _, _, CharNo), integer(CharNo)
    ->  true
    ;   string_length(Text, CharNo)
    ),
    syntax_error_at(What, Text, CharNo).

syntax_error_at(What, Text, CharNo) :-
    text_to_string(Text, String),
    throw(error(syntax_error(What), string(String, CharNo))).

%!  rtl_read_ground(+Text, -Term) is det.
%
%   Read Text as one ground term: a type error `ground` for a term with variables.

rtl_read_ground(Text, Term) :-
    rtl_read_text(Text, Term, _, []),
    (   ground(Term)
    ->  true
    ;   throw(error(type_error(ground, Term), context(_, 'the term must not have variables')))
    ).

%!  rtl_read_event(+Text, -Event) is det.
%
%   Read an event: a ground atom or compound term.

rtl_read_event(Text, Event) :-
    rtl_read_ground(Text, Event),
    (   callable(Event)
    ->  true
    ;   throw(error(type_error(event, Event), context(_, 'an event is an atom or a compound term')))
    ).

%!  rtl_ground_canonical(+Text, -Canonical:string) is det.
%
%   Read Text as one term and write it back with write_canonical/1 conventions (quoted, no
%   operators): the form the Python data-term reader handles. A term with variables gives
%   `"!not ground: variable Name"` instead.

rtl_ground_canonical(Text, Canonical) :-
    rtl_read_text(Text, Term, Bindings, []),
    (   Bindings = [Name=_|_]
    ->  format(string(Canonical), '!not ground: variable ~w', [Name])
    ;   \+ ground(Term)
    ->  Canonical = "!not ground"
    ;   with_output_to(string(Canonical), rtl_write_readable(current_output, Term))
    ).

%!  rtl_write_readable(+Out, +Term) is det.
%
%   Write Term as write_canonical/2 does (quoted, no operators, no `'$VAR'` naming, shared
%   variables named and singletons `_`), but with the non-ASCII characters that need it
%   written as `\uXXXX`/`\UXXXXXXXX` escapes: write_canonical/2 of SWI-Prolog 9 writes the
%   code points U+D8000..U+DFFFF as `\xD8000\`, which its own reader refuses ("Illegal
%   character code"), so a term holding one could not be read back. These options write
%   every code point 1..0x10FFFF in a form read_term/2 reads back.

rtl_write_readable(Out, Term) :-
    term_variables(Term, Vars),
    term_singletons(Term, Singletons),
    variable_names(Vars, Singletons, 0, Names),
    write_term(Out, Term, [ quoted(true), ignore_ops(true), dotlists(false), brace_terms(false), numbervars(false),
                            quote_non_ascii(true), character_escapes_unicode(true),
                            variable_names(Names)
                          ]).

variable_names([], _, _, []).
variable_names([V|Vs], Singletons, I, [Name=V|Names]) :-
    (   member(S, Singletons), S == V
    ->  Name = '_',
        I1 = I
    ;   variable_name(I, Name),
        I1 is I + 1
    ),
    variable_names(Vs, Singletons, I1, Names).

variable_name(I, Name) :-                          % A, ..., Z, A1, ..., Z1, A2, ...
    Letter is 0'A + I mod 26,
    N is I // 26,
    (   N =:= 0
    ->  char_code(Name, Letter)
    ;   format(atom(Name), '~c~d', [Letter, N])
    ).
