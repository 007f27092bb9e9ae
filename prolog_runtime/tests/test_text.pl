/*  plunit tests of rtl_text.pl: untrusted text read as exactly one term (a full stop at the
    end allowed, nothing after it), syntax errors raised with the text and the position, and
    the ground and event forms.

        swipl -g run_tests -t halt prolog_runtime/tests/test_text.pl
*/
:- use_module(library(plunit)).
:- use_module('../rtl_text').

syntax_error_of(Text, What, At) :-
    catch(( rtl_read_text(Text, _, _, []), fail ),
          error(syntax_error(What), string(String, At)),
          assertion(String == Text)).

:- begin_tests(rtl_text).

test(one_term) :-
    rtl_read_text("a(1, X, 'b c')", T, B, []),
    T = a(1, V, Q), assertion(var(V)), assertion(Q == 'b c'), assertion(B == [ 'X'=V ]).

test(a_full_stop_and_layout_are_allowed) :-
    rtl_read_text("  f(x) . \n", T, _, []), assertion(T == f(x)),
    rtl_read_text("g", G, _, []), assertion(G == g).

test(anything_after_the_term_is_an_error) :-
    syntax_error_of("a(1). halt", What, At),
    assertion(What == end_of_clause_expected), assertion(At == 4),
    syntax_error_of("a(1) b", What2, _), assertion(What2 \== '').

test(a_comment_after_the_term_is_layout) :-
    rtl_read_text("a(1). % done", T, _, []), assertion(T == a(1)).

test(empty_text) :-
    syntax_error_of("", empty_text, 0),
    syntax_error_of(" \t\n", empty_text, 0).

test(a_bad_term_says_where) :-
    syntax_error_of("a(", _, At), assertion(integer(At)).

test(ground) :-
    rtl_read_ground("p([1, 2], \"s\")", T), assertion(T == p([1, 2], "s")),
    catch(rtl_read_ground("p(X)", _), error(type_error(ground, _), _), true).

test(events_are_callable) :-
    rtl_read_event("door(open)", E), assertion(E == door(open)),
    catch(( rtl_read_event("42", _), fail ), error(type_error(event, 42), _), true).

test(canonical_text) :-
    rtl_ground_canonical("f( 'a' ,  [1,2] )", C), assertion(C == "f(a,[1,2])"),
    rtl_ground_canonical("f(X, Y)", V), assertion(V == "!not ground: variable X"),
    rtl_ground_canonical("f(_)", U), assertion(U == "!not ground").         % `_` is named nowhere

test(the_text_is_never_run) :-
    nb_setval(rtl_text_test_ran, false),
    rtl_read_text("nb_setval(rtl_text_test_ran, true)", T, _, []),
    assertion(T = nb_setval(_, true)),
    nb_getval(rtl_text_test_ran, Ran), assertion(Ran == false).

test(not_text, [throws(error(type_error(text, 42), _))]) :-
    rtl_read_text(42, _, _, []).

% rtl_write_readable/2 writes what write_canonical/2 writes, and reads back where that does not.
test(write_readable_is_canonical_for_ascii) :-
    T = f({a}, [b|_], X, X, '$VAR'(1), "s", 1.0Inf, -(1), a:b, [], 'A b'),
    with_output_to(string(S1), write_canonical(T)),
    with_output_to(string(S2), rtl_write_readable(current_output, T)),
    assertion(S1 == S2).

test(write_readable_reads_back_every_range) :-
    forall(member(C, [1, 0x7f, 0xe9, 0xD7FF, 0xE000, 0xFFFF, 0x1F600, 0xD8000, 0xDABCD, 0xDFFFF, 0x10FFFF]),
           (   atom_codes(A, [C]), string_codes(Str, [0'x, C]),
               with_output_to(string(S), rtl_write_readable(current_output, g(A, Str))),
               term_string(T, S),
               assertion(T == g(A, Str))
           )).

:- end_tests(rtl_text).
