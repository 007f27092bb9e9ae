"""One rule's code: the preparation every step needs (the variables an `or` may leave
unbound, the branch of each `or` under a policy, where each step's results go), then, per
step, the clauses of its operator family and those of its result (`outputs`)."""
from __future__ import annotations

from typing import Callable, Dict

from ...frontend.terms import Compound
from ..unit import BinaryRule, GeneratedRule, Step
from . import absence, aggregates, fnot, joins, negation, outputs, sliding
from .clauses import V, operand_vars
from .generator import RuleGenerator

Family = Callable[[RuleGenerator, Step], None]

#: The operator family of the steps whose operator names it; the other steps are `sliding`
#: (numbered when a policy step takes its changes), `or` and single-operand steps (forwarded)
#: or joins (`joins`, with `first` selecting in them).
FAMILIES: Dict[str, Family] = {
    "cnot": negation.negation_clauses,
    "fnot": fnot.fnot_clauses,
    "aggregate": aggregates.aggregate_clauses,
    "absence": absence.absence_clauses,
}


def family(g: RuleGenerator, step: Step) -> Family:
    """The function that adds the clauses of `step`."""
    if step.op in FAMILIES:
        return FAMILIES[step.op]
    if step.op == "sliding" and (g.provenance or g.policy in ("recent", "chronological")):
        # its changes reach a policy step (of this rule or of a rule it feeds)
        return sliding.numbered_sliding_clauses
    if step.op == "sliding":
        return sliding.sliding_clauses
    if step.right is None or step.op == "or":
        return joins.forward_clauses
    return joins.join_clauses


def generate(rule: BinaryRule, policy: str, provenance: bool = False) -> GeneratedRule:
    """The clauses of `rule` under `policy` (`provenance`: its head is an input of a policy
    step, so its instances carry their arrival numbers)."""
    g = RuleGenerator(rule, policy, provenance)
    for step in g.rule.steps:
        if step.op == "or":
            left_names = {v.name for v in operand_vars(step.left)}
            right_names = {v.name for v in operand_vars(step.right)}
            g.unbound |= left_names ^ right_names
    if g.policy in ("recent", "chronological"):
        # Under a consumption policy a partial match carries the branch of each `or` it
        # came through: `a(X) or b(X)` makes different partial matches of a(1) and b(1)
        # (no twins of each other under `recent`, and a deletion takes the right one).
        for step in g.rule.steps:
            if step.op == "or" and not step.derives_head:
                g.branches[step.name] = V(g.fresh("Branch"))
                step.output = Compound(step.output.name, step.output.args + (g.branches[step.name],))
    for step in g.rule.steps:
        for side, operand in (("left", step.left), ("right", step.right), ("negated", step.negated)):
            if operand is not None and operand.step is not None:
                g.consumers[operand.step.name] = (f"{step.name}_{side}", g.takes_arrivals(step, side))
    for step in g.rule.steps:
        family(g, step)(g, step)
        outputs.output_clauses(g, step)
    source = g.rule.rule
    comment = f"{source.span}: {source.source.strip()}"
    return GeneratedRule(g.rule.rule_id, comment, g.clauses, g.triggers, g.stores, g.records, g.kept, g.roles)
