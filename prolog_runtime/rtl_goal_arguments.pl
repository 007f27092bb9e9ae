:- module(rtl_goal_arguments,
          [ rtl_goal_arguments/3        % ?Name, ?Arity, ?Positions
          ]).

/** <module> Which arguments of the control constructs and meta-predicates are goals

The time terms `E^T` and `E^[T1, T2]` of a goal are rewritten (thesis 4.2.3: the time
becomes the last two arguments of E) in the goal itself and, through the control constructs
and meta-predicates listed here, in the arguments that are goals. One table for both roads
that rewrite goals: the compiler reads this file (retalisc/passes/slr_time_terms.py, for the
clauses, conditions and actions of a program) and the runtime loads it (rtl_query.pl,
rtl_time_goal/2, for the queries that arrive from outside). To let a new construct carry
time terms, add it here; tests/test_time_terms_roads.py checks that the two
roads rewrite alike.

The compiler reads the file with its own term reader: keep it to the module directive and
facts of rtl_goal_arguments/3.
*/

%!  rtl_goal_arguments(?Name, ?Arity, ?Positions:list(integer)) is nondet.
%
%   The arguments at Positions (1-based, as arg/3 counts) of Name/Arity are goals.

rtl_goal_arguments(',', 2, [1, 2]).
rtl_goal_arguments(;, 2, [1, 2]).
rtl_goal_arguments(->, 2, [1, 2]).
rtl_goal_arguments(*->, 2, [1, 2]).
rtl_goal_arguments(\+, 1, [1]).
rtl_goal_arguments(call, 1, [1]).
rtl_goal_arguments(once, 1, [1]).
rtl_goal_arguments(ignore, 1, [1]).
rtl_goal_arguments(forall, 2, [1, 2]).
rtl_goal_arguments(findall, 3, [2]).
rtl_goal_arguments(findall, 4, [2]).
rtl_goal_arguments(aggregate_all, 3, [2]).
rtl_goal_arguments(aggregate_all, 4, [3]).
