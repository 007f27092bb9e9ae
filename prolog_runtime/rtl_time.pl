:- module(rtl_time,
          [ rtl_time_seconds/2,          % +TimeIn, -Seconds
            rtl_interval_seconds/3       % +IntervalIn, -Start, -End
          ]).

/** <module> Time stamps at the edges of Retalis

Inside the runtime every time is a number of seconds (integer or float). At the edges we
also accept ROS stamps `[Secs, NSecs]` and the `datime(Y, M, D, H, Min, S, Counter)` terms of
the original ETALIS/Retalis, which we read as UTC seconds since the epoch (the counter,
ETALIS's tie breaker within one second, is added as a fraction of a millisecond so that
order within a second is kept).
*/

%!  rtl_time_seconds(+Time, -Seconds:number) is semidet.
%
%   Seconds for a time written as a number, `[Secs, NSecs]` or `datime/7` (`datime/6`).
%   Fails for anything else.

rtl_time_seconds(T, T) :-
    number(T), !.
rtl_time_seconds([Secs, NSecs], Seconds) :-
    integer(Secs), integer(NSecs), !,
    (   NSecs =:= 0
    ->  Seconds = Secs
    ;   Seconds is Secs + NSecs / 1.0e9
    ).
rtl_time_seconds(datime(Y, M, D, H, Min, S, Counter), Seconds) :-
    number(Counter), !,
    rtl_time_seconds(datime(Y, M, D, H, Min, S), Base),
    Seconds is Base + Counter / 1.0e6.
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
