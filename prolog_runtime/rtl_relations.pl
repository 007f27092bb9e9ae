:- module(rtl_relations,
          [ rtl_relation/6,             % ?Op, ?Left, ?Right, -Goals, -Start, -End
            rtl_blocker/5,              % ?Op, ?Left, ?Right, ?Blocker, -Goals
            rtl_blocker_window/5,       % ?Op, ?Left, ?Blocker, -From, -To
            rtl_absence_result/4,       % ?Left, ?Duration, -Start, -End
            rtl_window/4                % ?From, ?To, ?Window, -Goal
          ]).

/** <module> The temporal relations of the operators: one table for the compiler and explain

Each operator's temporal relation, as data: the arithmetic goals on the intervals of its
operands and the interval of its result. Intervals are Start-End pairs: the left operand's
S1-E1, the right one's S2-E2, a negated (blocking) event's SN-EN.

One table for both readers: the compiler reads this file (retalisc/frontend/relations.py,
for the `edbc` pass, retalisc/passes/edbc/, which compiles the goals into the clauses of every
step) and the runtime loads it (rtl_trace.pl, whose `retalisc explain` evaluates the rules'
patterns over the logged events with these goals). To change what an operator means, change
it here; tests/test_explain_agrees.py checks that explain finds exactly the detections of
the compiled program.

The compiler reads the file with its own term reader and keeps the variable names: keep it to
the module directive and facts, with S1, E1, S2, E2, SN, EN, D, W, From and To as the names
(`_E1`: E1, not used by the fact).
*/

%!  rtl_relation(?Op, ?Left, ?Right, -Goals:list, -Start, -End) is nondet.
%
%   The binary operator Op holds between Left (S1-E1) and Right (S2-E2) when the arithmetic
%   comparisons Goals hold; its result is over [Start, End] (expressions). `cnot` is the
%   relation of the pair of `not(N).[L, R]` (its blocker: rtl_blocker/5).

rtl_relation(seq, S1-E1, S2-E2, [E1 < S2], S1, E2).
rtl_relation(and, S1-E1, S2-E2, [], min(S1, S2), max(E1, E2)).
rtl_relation(par, S1-E1, S2-E2, [S1 < E2, S2 < E1], min(S1, S2), max(E1, E2)).
rtl_relation(equals, S1-E1, S2-E2, [S1 =:= S2, E1 =:= E2], S1, E1).
rtl_relation(meets, S1-E1, S2-E2, [E1 =:= S2], S1, E2).
rtl_relation(during, S1-E1, S2-E2, [S2 < S1, E1 < E2], S2, E2).
rtl_relation(starts, S1-E1, S2-E2, [S1 =:= S2, E1 < E2], S1, E2).
rtl_relation(finishes, S1-E1, S2-E2, [E1 =:= E2, S2 < S1], S2, E1).
rtl_relation(cnot, S1-E1, S2-E2, [E1 < S2], S1, E2).

%!  rtl_blocker(?Op, ?Left, ?Right, ?Blocker, -Goals:list) is nondet.
%
%   A negated event over Blocker (SN-EN) blocks the match of Op when Goals hold: for
%   `not(N).[L, R]` (cnot) an N strictly between L (S1-E1) and R (S2-E2); for `L fnot N`
%   (Right `none`) an N that ended before L started; for `not(N).[L, D]` (absence, Right the
%   result's interval, rtl_absence_result/4) an N that starts after L ends and ends by the
%   result's end.

rtl_blocker(cnot, _S1-E1, S2-_E2, SN-EN, [E1 < SN, EN < S2]).
rtl_blocker(fnot, S1-_E1, none, _SN-EN, [EN < S1]).
rtl_blocker(absence, _S1-E1, _S2-E2, SN-EN, [E1 < SN, EN =< E2]).

%!  rtl_blocker_window(?Op, ?Left, ?Blocker, -From, -To) is nondet.
%
%   Inside a window, a blocker of Op counts only when [From, To] fits the window
%   (rtl_window/4): for `fnot`, an N that starts within the window of L's end.

rtl_blocker_window(fnot, _S1-E1, SN-_EN, SN, E1).

%!  rtl_absence_result(?Left, ?Duration, -Start, -End) is det.
%
%   The interval of the result of `not(N).[L, D]`: from L's start to D after L's end.

rtl_absence_result(S1-E1, D, S1, E1 + D).

%!  rtl_window(?From, ?To, ?Window, -Goal) is det.
%
%   `(P).W`: the interval [From, To] (of a match, or rtl_blocker_window/5) fits the window
%   when Goal holds.

rtl_window(From, To, W, To - From =< W).
