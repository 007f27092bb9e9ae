"""edbc: generate the event-driven backward-chaining rules of every step (thesis 6.3.1,
Algorithms 1 and 2) as Prolog clause terms.

For a step `e <- L op R` the add rules are, per side (shown for the left side):

    e_left(LVars, LStart, LEnd) :-                  % an instance of L has occurred
        forall(( e_rights(Key, ROther, RStart, REnd),  % every R seen so far with the same key
                 <temporal relation of op>, <window> ),
               e(Vars, Start, End)),                 % ... completes e
        assertz(e_lefts(Key, LOther, LStart, LEnd)). % remember L for R's still to come

and the delete rules (`e_left_retract`, ...) remove the stored instance and retract every
result it took part in (`e_retract`). Stores are symmetric, so a match is found whichever
of its events arrives last: the result does not depend on arrival order (thesis 3.3.2).
The join variables come first in a stored partial match, so SWI-Prolog's just-in-time index
finds the partners by key instead of scanning every pending match.

Negation (`cnot`: no N between L and R; `fnot`: no N before L) derives eagerly and takes a
result back when a blocking event arrives late; deleting the blocker derives it again.

Under the `recent` and `chronological` consumption policies (ETALIS), an arriving event
joins with the newest (or oldest) waiting partner only, and both are consumed; the match is
recorded (`e_matched`), and every instance carries its position (its arrival number), so that
deleting an event rewinds the step and replays its later arrivals
(prolog_runtime/rtl_policy.pl): the output is that of a run without the deleted event.

Deletions and late events (prolog_runtime/rtl_horizon.pl): the runtime moves the partial
matches a windowed step no longer needs for events within the delay bound to the store's kept
generations (`_kept_a`, `_kept_b`), and keeps them there for the retraction horizon. Only an
instance that is late (`rtl_late(End)`) searches them: an instance within the bound cannot
match them. An aggregate numbers its instances in processing order and records its P's, so
that deleting an A or a P replays the values it changed.

The pass is split by operator family, one module each, on a shared core:

- `steps`: the pass's work per rule: the preparation, then each step's family and result;
- `generator` (the state of one rule's generation), `stores` (partial matches, kept and
  rotated records), `clauses` (terms and clauses), `relations` (the binary operators'
  temporal relations), `rule_policies` (each rule's consumption policy);
- the families: `joins` (the binary operators, `or`, single operands), `first` (the `first`
  selection in joins), `policies` (`recent`/`chronological`: consuming, rewinding),
  `negation` (`cnot`, and the blocker search `fnot` and `absence` share), `fnot`,
  `absence`, `sliding` (sliding windows), `aggregates`, `alarms` (timer heads) and
  `outputs` (a step's result: the next step, or the derived head).
"""
from __future__ import annotations

from ..unit import Unit
from .alarms import alarm_head
from .rule_policies import RULE_POLICIES, policy_inputs, rule_policy, signature
from .steps import generate

name = "edbc"

__all__ = ["RULE_POLICIES", "alarm_head", "name", "policy_inputs", "rule_policy", "run", "signature"]


def run(unit: Unit) -> Unit:
    policies = [rule_policy(unit, rule) for rule in unit.rules]
    consumed = policy_inputs(unit.rules, policies)
    unit.generated = [generate(rule, policy, provenance=policy not in ("recent", "chronological")
                               and signature(rule.rule.head) in consumed)
                      for rule, policy in zip(unit.rules, policies)]
    return unit
