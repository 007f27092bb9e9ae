:- module(rtl_guard,
          [ rtl_reserved_ball/1,        % @Ball
            rtl_is_reserved_ball/1,     % @Ball
            rtl_format_text/1,          % @Format
            rtl_catch/3,                % :Goal, ?Catcher, :Recovery
            rtl_throw/1,                % +Ball
            rtl_format/1,               % +Format
            rtl_format/2,               % +Format, :Args
            rtl_format/3,               % +Sink, +Format, :Args
            rtl_format_directive/2,     % +Format, -Refused
            rtl_output_sink/1,          % @Sink
            rtl_condition_raised/3      % +Error, +Format, +Args
          ]).

/** <module> Run-time guards of untrusted goals

Some goals of untrusted code can only be judged when they run: the ball of throw/1, what a
catch/3 catches, a format string given by data. The sandbox (rtl_sandbox.pl) rewrites them
into the guarded predicates here when it checks the goal:

  - rtl_catch/3 is catch/3 that never catches a reserved ball (rtl_reserved_ball/1): the
    time and step limits, `'$aborted'`, `unwind(_)` and the runtime's own balls pass
    through it untouched, so untrusted code cannot outlive its limits or stop a run.
  - rtl_throw/1 is throw/1 refusing a reserved ball (a permission error instead).
  - rtl_format/1,2,3 check the format string when it is known: no `~@` (calls a goal), `~W`
    (takes write options, such as `portray_goal`), `~p` (calls the program's portray
    hooks); the sink of rtl_format/3 must be `atom(_)`, `string(_)`, `codes(_)`,
    `codes(_, _)`, `chars(_)` or `chars(_, _)`.
*/

:- use_module(library(lists)).
:- use_module(rtl_error_text, [rtl_error_text/2]).

:- meta_predicate rtl_catch(0, ?, 0).

%!  rtl_reserved_ball(@Ball) is semidet.
%
%   Ball (or a ball it may become) is one untrusted code may neither throw nor catch: the
%   limits of SWI-Prolog (`time_limit_exceeded`, `inference_limit_exceeded`), an abort
%   (`'$aborted'`, `unwind(_)`), and the runtime's step limit, halts, stops and refusals.

rtl_reserved_ball(Ball) :-
    var(Ball), !.
rtl_reserved_ball(Ball) :-
    reserved(R),
    \+ Ball \= R, !.

reserved('$aborted').
reserved(time_limit_exceeded).
reserved(time_limit_exceeded(_)).
reserved(inference_limit_exceeded).
reserved(unwind(_)).
reserved(rtl_halted(_)).
reserved(rtl_stop(_)).
reserved(rtl_signal(_)).
reserved(rtl_state_unwritable(_)).
reserved(error(rtl_step_limit(_), _)).
reserved(error(rtl_unsafe(_, _, _), _)).

%!  rtl_catch(:Goal, ?Catcher, :Recovery)
%
%   catch/3, except that a reserved ball is never caught.

rtl_catch(Goal, Catcher, Recovery) :-
    catch(Goal, Ball, recover(Ball, Catcher, Recovery)).

recover(Ball, Catcher, Recovery) :-
    (   rtl_is_reserved_ball(Ball)
    ->  throw(Ball)
    ;   Ball = Catcher
    ->  call(Recovery)
    ;   throw(Ball)
    ).

%!  rtl_is_reserved_ball(@Ball) is semidet.
%
%   Ball is a reserved ball whatever its variables become (a ball as catch/3 sees it is a
%   copy: its variables are its own).

rtl_is_reserved_ball(Ball) :-
    nonvar(Ball),
    reserved(R),
    subsumes_term(R, Ball), !.

%!  rtl_throw(+Ball)
%
%   throw/1 for untrusted code: a reserved ball raises a permission error instead.

rtl_throw(Ball) :-
    (   var(Ball)
    ->  throw(Ball)                             % instantiation error, as throw/1
    ;   rtl_is_reserved_ball(Ball)
    ->  throw(error(permission_error(throw, reserved_ball, Ball), context(throw/1, _)))
    ;   throw(Ball)
    ).

%!  rtl_format(+Format)
%!  rtl_format(+Format, :Args)
%!  rtl_format(+Sink, +Format, :Args)
%
%   format/1,2,3 once the format string passed rtl_format_directive/2.

rtl_format(Format) :-
    rtl_format(Format, []).

rtl_format(Format, Args) :-
    checked_format(Format),
    format(Format, Args).

rtl_format(Sink, Format, Args) :-
    (   rtl_output_sink(Sink)
    ->  true
    ;   throw(error(permission_error(output, sink, Sink), context(format/3, _)))
    ),
    checked_format(Format),
    format(Sink, Format, Args).

checked_format(Format) :-
    (   rtl_format_directive(Format, Refused)
    ->  throw(error(permission_error(use, format_directive, Refused), context(format/2, _)))
    ;   true
    ).

%!  rtl_output_sink(@Sink) is semidet.
%
%   Sink is one untrusted code may write to with format/3 or with_output_to/2: a string, an
%   atom, codes or chars, never a stream.

rtl_output_sink(S) :- var(S), !, fail.
rtl_output_sink(atom(_)).
rtl_output_sink(string(_)).
rtl_output_sink(codes(_)).
rtl_output_sink(codes(_, _)).
rtl_output_sink(chars(_)).
rtl_output_sink(chars(_, _)).

%!  rtl_condition_raised(+Error, +Format, +Args) is failure.
%
%   The runtime's handler of an error raised by the conditions of a subscription, a memory
%   or a synchronized query: a reserved ball (a limit) is raised again, so it ends the
%   event; any other is a warning, Format with Args and the error's text (rtl_error_text/2)
%   after them, and the condition fails.

rtl_condition_raised(Error, Format, Args) :-
    (   rtl_is_reserved_ball(Error)
    ->  throw(Error)
    ;   rtl_error_text(Error, Text),
        append(Args, [Text], All),
        print_message(warning, format(Format, All)),
        fail
    ).

%!  rtl_format_directive(+Format, -Refused:atom) is semidet.
%
%   Format (text, codes or chars) has a directive untrusted code may not use; Refused is
%   it (`'~@'`). Fails when every directive is allowed. A Format that is not text is left
%   to format/2 (which raises the error).

rtl_format_directive(Format, Refused) :-
    format_codes(Format, Codes),
    refused_directive(Codes, Refused).

%!  rtl_format_text(@Format) is semidet.
%
%   Format is a whole format string (text, a proper list of codes or of chars), so that
%   rtl_format_directive/2 can judge it now.

rtl_format_text(Format) :-
    format_codes(Format, _).

format_codes(Format, Codes) :-
    (   string(Format) -> string_codes(Format, Codes)
    ;   atom(Format) -> atom_codes(Format, Codes)
    ;   is_list(Format), Format = [C|_], integer(C) -> Codes = Format
    ;   is_list(Format), Format = [C|_], atom(C) -> catch(atom_chars(A, Format), _, fail), atom_codes(A, Codes)
    ).

refused_directive([0'~|Cs], Refused) :- !,
    directive_argument(Cs, Rest),
    (   Rest = [0':|Rest1] -> true ; Rest1 = Rest ),      % ~:d
    (   Rest1 = [D|More]
    ->  (   allowed_directive(D)
        ->  refused_directive(More, Refused)
        ;   atom_codes(Refused, [0'~, D])
        )
    ;   fail                                        % a ~ at the end: format/2 raises
    ).
refused_directive([_|Cs], Refused) :-
    refused_directive(Cs, Refused).

directive_argument([0'*|Cs], Cs) :- !.
directive_argument([0'`, _|Cs], Cs) :- !.
directive_argument(Cs0, Cs) :-
    digits(Cs0, Cs).

digits([C|Cs0], Cs) :-
    code_type(C, digit), !,
    digits(Cs0, Cs).
digits(Cs, Cs).

allowed_directive(0'a).
allowed_directive(0'c).
allowed_directive(0'd).
allowed_directive(0'D).
allowed_directive(0'e).
allowed_directive(0'f).
allowed_directive(0'g).
allowed_directive(0'i).
allowed_directive(0'I).
allowed_directive(0'k).
allowed_directive(0'n).
allowed_directive(0'q).
allowed_directive(0'r).
allowed_directive(0'R).
allowed_directive(0's).
allowed_directive(0'w).
allowed_directive(0'~).
allowed_directive(0't).
allowed_directive(0'|).
allowed_directive(0'+).
