/*  plunit tests of rtl_time.pl: the time stamps taken at the edges (seconds, ROS stamps
    [Secs, NSecs], datime/6,7 read as UTC), the time of an input line (`t`, or `start` and
    `end`) with its problems, and the one reading of "further behind the clock than a bound".

        swipl -g run_tests -t halt prolog_runtime/tests/test_time.pl
*/
:- use_module(library(plunit)).
:- use_module(library(lists)).
:- use_module(library(random)).
:- use_module('../rtl_time').

:- begin_tests(rtl_time).

test(numbers_are_seconds) :-
    rtl_time_seconds(5, A), assertion(A == 5),
    rtl_time_seconds(2.5, B), assertion(B == 2.5),
    rtl_time_seconds(-3, C), assertion(C == -3).

test(ros_stamps) :-
    rtl_time_seconds([7, 0], A), assertion(A == 7),                 % whole seconds stay integers
    rtl_time_seconds([7, 500000000], B), assertion(B =:= 7.5),
    rtl_time_seconds([0, 1], C), assertion(C =:= 1.0e-9).

test(not_a_time, [fail]) :-
    rtl_time_seconds(soon, _).

test(not_a_stamp, [fail]) :-
    rtl_time_seconds([1.5, 3], _).

test(datime_is_utc) :-
    rtl_time_seconds(datime(1970, 1, 1, 0, 0, 0), Epoch), assertion(Epoch =:= 0),
    rtl_time_seconds(datime(2015, 6, 1, 12, 30, 15), S),
    assertion(S =:= 1433161815).

test(datime_counter_is_nanoseconds_like_a_ros_stamp) :-
    rtl_time_seconds(datime(2015, 6, 1, 12, 30, 15, 250000000), D),
    rtl_time_seconds([1433161815, 250000000], R),
    assertion(D == R),
    rtl_time_seconds(datime(2015, 6, 1, 12, 30, 15, 0), Z),
    assertion(Z =:= 1433161815).

test(datime_counter_out_of_range, [fail]) :-
    rtl_time_seconds(datime(2015, 6, 1, 12, 30, 15, 1000000000), _).

test(intervals) :-
    rtl_interval_seconds([1, [2, 500000000]], S, E), assertion(S-E == 1-2.5),
    rtl_interval_seconds(4, S1, E1), assertion(S1-E1 == 4-4).

test(input_interval_from_t) :-
    rtl_input_interval(3, _, _, S, E, P),
    assertion(var(P)), assertion(S-E == 3-3).

test(input_interval_from_start_and_end) :-
    rtl_input_interval(_, 1, [2, 0], S, E, P),
    assertion(var(P)), assertion(S-E == 1-2).

test(input_interval_problems) :-
    problem(t(1, 1, 2), "give either \"t\" or \"start\" and \"end\", not both"),
    problem(t(_, _, _), "missing time: give \"t\", or \"start\" and \"end\""),
    problem(t(_, 1, _), "missing time: give \"t\", or \"start\" and \"end\""),
    problem(t(_, 3, 2), "\"start\" is after \"end\""),
    problem(t(soon, _, _), "\"t\" must be a finite number of seconds or [secs, nsecs]"),
    problem(t(_, 1, inf), "\"end\" must be a finite number of seconds or [secs, nsecs]"),
    problem(t([1, 2000000000], _, _), "\"t\": nanoseconds must be in [0, 1e9), not 2000000000"),
    problem(t([1, -1], _, _), "\"t\": nanoseconds must be in [0, 1e9), not -1"),
    Big is 2^1100,
    problem(t(Big, _, _), "\"t\" must be a finite number of seconds or [secs, nsecs] (beyond a float)"),
    NaN is nan,
    problem(t(NaN, _, _), "\"t\" must be a finite number of seconds or [secs, nsecs]").

problem(t(T, S, E), Expected) :-
    rtl_input_interval(T, S, E, _, _, Problem),
    assertion(Problem == Expected).

test(beyond_the_bound) :-
    assertion(rtl_beyond_bound(1, 10, 5)),
    assertion(\+ rtl_beyond_bound(5, 10, 5)),                   % exactly the bound: not beyond
    assertion(\+ rtl_beyond_bound(1, 10, inf)),
    assertion(rtl_beyond_bound(-inf, 0, 5)),
    assertion(\+ rtl_beyond_bound(inf, 1.0e300, 5)).

% Against the definition End + Bound < Clock on random finite numbers.
test(beyond_the_bound_is_end_plus_bound_below_clock) :-
    set_random(seed(36)),
    forall(between(1, 2000, _),
           ( random_between(-50, 50, End), random_between(-50, 50, Clock), random_between(0, 20, Bound),
             (   End + Bound < Clock
             ->  assertion(rtl_beyond_bound(End, Clock, Bound))
             ;   assertion(\+ rtl_beyond_bound(End, Clock, Bound))
             ) )).

:- end_tests(rtl_time).
