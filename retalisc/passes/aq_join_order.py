"""aq_join_order: place each builtin where its arguments are bound, then order each rule's body for
the arguments its calls bind (an adorned join order).

Builtins first, in every mode: XSB programs write tests where they read well (`q(X, Y) :- X < Y,
e(X, Y).`), and XSB evaluates them once their arguments are bound.  A builtin that is not ready
where it is written (a test or `\\+ Builtin` with a variable unbound there, `is/2` with an unbound
variable on its right; the head's variables count as unbound: a call may leave them so) moves to
just after the first literal from which on it is ready; the other literals keep their order.
A builtin that no position makes ready even with the head's variables bound by the call is
refused with a located error (it would raise an instantiation error whatever the call).

The transformed program records every state that waits on stored facts (a goal record) so that
later assertions find it; how many there are depends on the order of the body.  Program 6 of
the thesis asks `show(Artist, Price, L)` before `likes(User, Artist, MaxPrice, MaxDistance)`:
a query `notify(u1, A, P, L)` then leaves one state per show waiting on `likes(u1, ...)`, where
asking `likes` first (its first argument is bound) leaves one per artist the user likes.

For a rule whose head arguments are variables, every *adornment* (which of them a call binds)
gets the body order a greedy choice gives: the next user literal is the one with most bound
arguments, then the fewest variables still unbound, then the earliest; each builtin goes in as
soon as its variables are bound.
When the adornments give more than one order, the rule becomes one rule per order (its
`variant_of` the written rule's number), each for the masks in its `guard`; the backend gives
them one activation clause that computes the mask once (`aq_adornment(HeadVars, Mask)`) and
picks the order by it, so exactly one of them runs for a call.  A body is only reordered when that cannot change what it means:
Only in the tabled mode (variant tables terminate whatever the order; the Optimized mode,
with a table per call, might not). No `==`, `\\==` or negated builtin (they depend on what is bound), no negated literal, every
builtin's variables bound where it stands in the written order (for that adornment), and at
most 4 head variables (16 adornments).
"""
from __future__ import annotations

import copy
from typing import Dict, List, Optional, Set, Tuple

from ..frontend.definite import Literal, Program, Rule, program_error
from ..frontend.terms import Compound, Var, variables
from ..frontend.writer import write_term
from .unit import AqUnit

name = "aq_join_order"

MAX_HEAD_VARS = 4
_ORDER_SENSITIVE = {"==", "\\==", "\\=", "\\+", "@<", "@>", "@=<", "@>="}


def _vars(term) -> Set[str]:
    return {v.name for v in variables(term) if not v.is_anonymous}


def _builtin_ready(lit: Literal, bound: Set[str]) -> bool:
    return _needed(lit) <= bound


def _needed(lit: Literal) -> Set[str]:
    """The variables a builtin needs bound: none for `=`, the right side's for `is`, else all."""
    term = lit.term
    if isinstance(term, Compound) and term.name == "=" and term.arity == 2:
        return set()
    if isinstance(term, Compound) and term.name == "is" and term.arity == 2:
        return _vars(term.args[1])
    return _vars(term)


def _bind(lit: Literal, bound: Set[str]) -> None:
    term = lit.term
    if lit.kind != "builtin":
        bound |= _vars(term)
    elif isinstance(term, Compound) and term.name == "=" and term.arity == 2:
        left, right = _vars(term.args[0]), _vars(term.args[1])
        if left <= bound or right <= bound:
            bound |= left | right
    elif isinstance(term, Compound) and term.name == "is" and term.arity == 2:
        bound |= _vars(term.args[0])


def place_builtins(rule: Rule) -> List[Literal]:
    """`rule.body` with every builtin at the first position where it is ready (module docstring).
    Raises a located error for a builtin that is ready nowhere."""
    placed, waiting = _placed(rule.body, set(), set())
    if waiting:
        # ready only once the call binds head variables: where they first make it ready
        placed, waiting = _placed(rule.body, {id(lit) for lit, _ in waiting}, _vars(rule.head))
    for lit, bound in waiting:
        unbound = sorted(_needed(lit) - bound)
        raise program_error(
            f"{write_term(lit.term, 999)}: no order of this body binds {', '.join(unbound)} before this goal "
            f"(neither the head nor a literal of the body binds {'it' if len(unbound) == 1 else 'them'}): "
            "it would raise an instantiation error", lit.term, rule.span)
    return placed


def _placed(body: List[Literal], late: Set[int], head: Set[str]):
    """The body with each builtin where it is ready (the `late` ones counting the head's variables
    as bound), and the builtins never ready with the variables bound at the end."""
    placed: List[Literal] = []
    waiting: List[Literal] = []
    bound: Set[str] = set()

    def ready(lit: Literal) -> bool:
        return _builtin_ready(lit, bound | head if id(lit) in late else bound)

    def place(lit: Literal) -> None:
        placed.append(lit)
        _bind(lit, bound)
        while True:
            now = [w for w in waiting if ready(w)]
            if not now:
                return
            waiting.remove(now[0])
            placed.append(now[0])
            _bind(now[0], bound)

    for lit in body:
        if lit.kind == "builtin" and not ready(lit):
            waiting.append(lit)
        else:
            place(lit)
    return placed, [(lit, bound | head if id(lit) in late else bound) for lit in waiting]


def _written_order_ok(body: List[Literal], bound0: Set[str]) -> bool:
    bound = set(bound0)
    for lit in body:
        if lit.kind == "builtin" and not _builtin_ready(lit, bound):
            return False
        _bind(lit, bound)
    return True


def _bound_args(lit: Literal, bound: Set[str]) -> int:
    term = lit.term
    if not isinstance(term, Compound):
        return 0
    return sum(1 for a in term.args if _vars(a) <= bound)


def greedy_order(body: List[Literal], bound0: Set[str]) -> Optional[List[int]]:
    """The positions of `body` in the greedy order for head variables `bound0`, or None when
    a builtin can never be placed."""
    bound = set(bound0)
    left = list(range(len(body)))
    order: List[int] = []
    while left:
        ready = [i for i in left if body[i].kind == "builtin" and _builtin_ready(body[i], bound)]
        if ready:
            pick = ready[0]
        else:
            users = [i for i in left if body[i].kind != "builtin"]
            if not users:
                return None
            pick = max(users, key=lambda i: (_bound_args(body[i], bound), -len(_vars(body[i].term) - bound), -i))
        order.append(pick)
        left.remove(pick)
        _bind(body[pick], bound)
    return order


def _reorderable(rule: Rule) -> bool:
    for lit in rule.body:
        if lit.negated:
            return False
        term = lit.term
        if lit.kind == "builtin" and isinstance(term, Compound) and term.name in _ORDER_SENSITIVE:
            return False
    return sum(1 for lit in rule.body if lit.kind != "builtin") >= 2


def head_vars(rule: Rule) -> Optional[List[str]]:
    head = rule.head
    if not isinstance(head, Compound):
        return None
    names: List[str] = []
    for arg in head.args:
        if isinstance(arg, Var) and not arg.is_anonymous and arg.name not in names:
            names.append(arg.name)
    return names


def variants(rule: Rule) -> List[Tuple[List[int], List[int]]]:
    """[(masks, order)]: the adornments (bit i: head variable i bound) that share each order;
    one entry when reordering does not apply or changes nothing."""
    hv = head_vars(rule)
    identity = list(range(len(rule.body)))
    if not _reorderable(rule) or hv is None or not hv or len(hv) > MAX_HEAD_VARS:
        return [([], identity)]
    groups: Dict[Tuple[int, ...], List[int]] = {}
    for mask in range(1 << len(hv)):
        bound = {v for i, v in enumerate(hv) if mask >> i & 1}
        if not _written_order_ok(rule.body, bound):
            return [([], identity)]
        order = greedy_order(rule.body, bound)
        if order is None:
            return [([], identity)]
        groups.setdefault(tuple(order), []).append(mask)
    if len(groups) == 1:
        order = next(iter(groups))
        return [([], list(order))]
    return [(masks, list(order)) for order, masks in groups.items()]


def run(unit: AqUnit) -> AqUnit:
    program: Program = unit.program
    for rule in program.rules:
        rule.body = place_builtins(rule)
    if unit.mode != "tabled":
        # Optimized creates a table per call: an order that calls a recursive predicate with
        # fewer arguments bound may not terminate there; Naive's tables are per predicate
        return unit
    rules: List[Rule] = []
    for rule in program.rules:
        for masks, order in variants(rule):
            new = copy.copy(rule)
            new.body = [rule.body[i] for i in order]
            new.guard = (head_vars(rule), masks) if masks else None
            new.variant_of = rule.index if masks else 0
            rules.append(new)
    for k, rule in enumerate(rules, 1):
        rule.index = k
    program.rules = rules
    return unit
