:- module(rtl_time,
          [ rtl_time_seconds/2,          % +TimeIn, -Seconds
            rtl_interval_seconds/3,      % +IntervalIn, -Start, -End
            rtl_input_interval/6,        % ?T, ?Start, ?End, -StartSec, -EndSec, -Problem
            rtl_beyond_bound/3           % +End, +Clock, +Bound
          ]).

/** <module> Time stamps at the edges of Retalis

Inside the runtime every time is a number of seconds (integer or float). At the edges we
also accept ROS stamps `[Secs, NSecs]` and the `datime(Y, M, D, H, Min, S, Counter)` terms of
the original Retalis, which we read as UTC seconds since the epoch. The counter holds the
nanoseconds within the second, as in the 2015 release (thesis A.2.5: "Counter encodes
nanoseconds since seconds (i.e. stamp.nsec in ROS messages)"): an integer in [0, 10^9),
checked, so that a datime/7 and a ROS stamp of the same instant are the same time.

The delay bound and every other "how far behind the clock" bound (a memory's time limit,
the retraction horizon) are read the same way, by rtl_beyond_bound/3.
*/

%!  rtl_beyond_bound(+End:number, +Clock:number, +Bound) is semidet.
%
%   A time End lies beyond Bound seconds (a number, or `inf`: never) behind Clock:
%   `End + Bound < Clock`. An event that ends at End and arrives when the clock is Clock
%   is *late* (it breaks a delay bound Bound) exactly then; an event exactly Bound seconds
%   late is within the bound. So the history up to End is complete once End is beyond the
%   bound (no event ending at or before End can arrive within it any more), a record of a
%   memory with time limit Bound is forgotten then, and a deletion is too late then. Due
%   times kept in indexes (timers, deadlines) are `End + Bound`, due once strictly before
%   the clock: the same sum, so they agree with this test to the last bit.

rtl_beyond_bound(End, Clock, Bound) :-
    Bound \== inf,
    (   abs(End) =\= inf
    ->  End + Bound < Clock
    ;   End < Clock                             % -inf: beyond once the clock started; inf: never
    ).

%!  rtl_time_seconds(+Time, -Seconds:number) is semidet.
%
%   Seconds for a time written as a number, `[Secs, NSecs]` or `datime/7` (`datime/6`;
%   the counter of datime/7 is nanoseconds, an integer in [0, 10^9)). Fails for anything
%   else.

rtl_time_seconds(T, T) :-
    number(T), !.
rtl_time_seconds([Secs, NSecs], Seconds) :-
    integer(Secs), integer(NSecs), !,
    (   NSecs =:= 0
    ->  Seconds = Secs
    ;   Seconds is Secs + NSecs / 1.0e9
    ).
rtl_time_seconds(datime(Y, M, D, H, Min, S, NSecs), Seconds) :-
    integer(NSecs), between(0, 999999999, NSecs), !,
    rtl_time_seconds(datime(Y, M, D, H, Min, S), Base),
    (   NSecs =:= 0
    ->  Seconds = Base
    ;   Seconds is Base + NSecs / 1.0e9           % as a ROS stamp [Base, NSecs]
    ).
rtl_time_seconds(datime(Y, M, D, H, Min, S), Seconds) :-
    maplist(number, [Y, M, D, H, Min, S]),
    date_time_stamp(date(Y, M, D, H, Min, S, 0, -, -), Stamp),
    Seconds is Stamp.

%!  rtl_interval_seconds(+Interval, -Start, -End) is semidet.
%
%   Interval is a single time (an atomic event) or `[T1, T2]` of two times. A list of two
%   integers is an interval here: ROS stamps come in through rtl_time_seconds/2.

rtl_interval_seconds([T1, T2], Start, End) :-
    !,
    rtl_time_seconds(T1, Start),
    rtl_time_seconds(T2, End).
rtl_interval_seconds(T, Start, Start) :-
    rtl_time_seconds(T, Start).

%!  rtl_input_interval(?T, ?S, ?E, -Start, -End, -Problem) is det.
%
%   The time of an input event from its fields "t", "start" and "end" (unbound when absent):
%   Start and End in seconds, or Problem bound to a string saying why they do not give a
%   valid time. A time is a finite number of seconds or a ROS stamp `[Secs, NSecs]` with
%   NSecs in [0, 1e9). The one check of input times: event files (rtl_io.pl) and the Python
%   Engine (rtl_api.pl) both use it, so both accept and refuse the same times, with the same
%   reasons.

rtl_input_interval(T, S, E, Start, End, Problem) :-
    (   nonvar(T)
    ->  (   ( nonvar(S) ; nonvar(E) )
        ->  Problem = "give either \"t\" or \"start\" and \"end\", not both"
        ;   time_problem("t", T, Problem)
        ->  true
        ;   rtl_time_seconds(T, Start), End = Start
        )
    ;   nonvar(S), nonvar(E)
    ->  (   time_problem("start", S, Problem)
        ->  true
        ;   time_problem("end", E, Problem)
        ->  true
        ;   rtl_time_seconds(S, Start), rtl_time_seconds(E, End),
            (   Start > End -> Problem = "\"start\" is after \"end\"" ; true )
        )
    ;   Problem = "missing time: give \"t\", or \"start\" and \"end\""
    ).

%   time_problem(+Key, +Value, -Reason) is semidet.
%
%   Value (of field Key) is not a valid input time; Reason says why.

time_problem(Key, T, Reason) :-
    (   integer(T)
    ->  beyond_a_float(Key, T, Reason)
    ;   float(T), T =:= T, abs(T) =\= inf
    ->  fail
    ;   T = [Secs, NSecs], integer(Secs), integer(NSecs)
    ->  (   beyond_a_float(Key, Secs, Reason)
        ->  true
        ;   \+ between(0, 999999999, NSecs),
            format(string(Reason), "\"~s\": nanoseconds must be in [0, 1e9), not ~w", [Key, NSecs])
        )
    ;   format(string(Reason), "\"~s\" must be a finite number of seconds or [secs, nsecs]", [Key])
    ).

% An integer number of seconds beyond the largest float (the clock and the windows are
% computed in floats: such a time would raise float_overflow in every later event).
beyond_a_float(Key, Seconds, Reason) :-
    Seconds =\= 0,
    msb(abs(Seconds)) >= 1024,
    format(string(Reason), "\"~s\" must be a finite number of seconds or [secs, nsecs] (beyond a float)", [Key]).
