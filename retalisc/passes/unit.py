"""What the passes work on: the compilation units and the intermediate forms they carry.

`Unit` (event programs): the program model (`retalisc.frontend.program.Program`) comes in;
`binarize` adds the binary steps of every event rule (thesis 6.3.1, first step); `edbc` adds
the generated Prolog clauses as terms (Algorithms 1 and 2). A form is None until the pass that
makes it has run.

`AqUnit` (active queries): a definite program (`retalisc.frontend.definite.Program`) and the
transformation asked for.

Passes only build dataclasses and terms; the text of a unit, for the output or for
`--dump-after`, is made by the backend (`retalisc/backends/prolog/`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, FrozenSet, List, Optional, Tuple

from ..frontend import definite
from ..frontend.program import EventRule, Program
from ..frontend.terms import Span, Term


@dataclass
class Settings:
    """Program-wide settings collected from directives and declarations."""

    consumption_policy: str = "unrestricted"
    printed: Optional[List[tuple]] = None     # print_trigger selections (collect_settings._printed); None = all
    rule_properties: Dict[str, dict] = field(default_factory=dict)  # label -> {name: value}
    ros_strings: str = "plain"                # how a ROS string field is an atom (collect_settings.ROS_STRINGS)


@dataclass
class Operand:
    """One input of a step: an event pattern atom, or the output of another step."""

    term: Term                      # the event atom, or the intermediate event of `step`
    step: Optional["Step"] = None   # None for an event atom of the source
    filters: List[Term] = field(default_factory=list)  # where-conjuncts checked on arrival
    start: Optional[Term] = None    # variables bound by E^[Start, End]
    end: Optional[Term] = None
    span: Optional[Span] = None

    @property
    def is_event(self) -> bool:
        return self.step is None


@dataclass
class Step:
    """A binary rule `output <- left OP right` (or a unary pass-through, op `pass`), with the
    where-conditions checked on its result and the window its matches must fit in."""

    name: str                       # e_<rule>_<n>
    op: str                         # seq, and, par, or, equals, ..., cnot, fnot, absence, pass
    left: Operand
    right: Optional[Operand]
    output: Term                    # e_<rule>_<n>(Vars...) or, for the last step, the head
    window: Optional[float] = None
    conditions: List[Term] = field(default_factory=list)
    derives_head: bool = False
    negated: Optional[Operand] = None   # cnot: no `negated` between left and right;
                                        # fnot: no `negated` before left
    aggregate: Optional[tuple] = None   # (function, value variable) of `left seq aggregate(F, right, V)`
    duration: Optional[float] = None    # absence: no `negated` in the `duration` seconds after `left`
    sliding: Optional[tuple] = None     # (function, group term, value variable) of a sliding aggregate


@dataclass
class BinaryRule:
    """An event rule after binarization: its steps, innermost first, the last one deriving
    the head."""

    rule_id: str
    rule: EventRule
    steps: List[Step]


@dataclass
class GeneratedRule:
    """The Prolog clauses generated for one source rule, with what the runtime must know."""

    rule_id: str
    comment: str                    # the source rule and its location
    clauses: List[Term]
    triggers: List[Term]            # ele_trigger/3 clauses
    stores: List[tuple]             # (name, arity, window or None)
    # kept for deletions and late events (prolog_runtime/rtl_horizon.pl): record stores as
    # (name, arity, its two generations), and (live store, arity, its two kept generations,
    # "newest_first" or "oldest_first")
    records: List[tuple] = field(default_factory=list)
    kept: List[tuple] = field(default_factory=list)
    # what each store and record holds: name -> (the step's name, `lefts`, `rights`, `negs`,
    # `matched`, ...), for the tools that show them (`retalisc run --trace`)
    roles: Dict[str, Tuple[str, str]] = field(default_factory=dict)


@dataclass(frozen=True)
class TargetPredicates:
    """What the generated module sees without defining it, by (name, arity): SWI-Prolog's
    builtins, its autoloaded library and the Retalis runtime's predicates (with their module).
    The backend knows them (`backends/prolog/reserved.py`); the compiler hands them to the unit."""

    builtins: FrozenSet[Tuple[str, int]] = frozenset()
    library: FrozenSet[Tuple[str, int]] = frozenset()
    runtime: Dict[Tuple[str, int], str] = field(default_factory=dict)
    generated: FrozenSet[Tuple[str, int]] = frozenset()   # defined by every generated module

    def known(self, key: Tuple[str, int]) -> bool:
        return key in self.builtins or key in self.library or key in self.runtime


@dataclass
class Unit:
    program: Program
    module: str
    settings: Settings = field(default_factory=Settings)
    rules: Optional[List[BinaryRule]] = None          # set by binarize
    generated: Optional[List[GeneratedRule]] = None   # set by edbc
    warnings: List[str] = field(default_factory=list)
    rule_prefix: str = "rt"  # added_rules: unlabelled rules added at run time are named <prefix>_<n>
    target: TargetPredicates = field(default_factory=TargetPredicates)
    # runtime library predicates (min/3, new_event/1, ...) the program defines itself: the
    # generated module does not import them (set by `loadable`)
    runtime_overrides: List[Tuple[str, int]] = field(default_factory=list)
    # what the `lint` pass found (LintWarning objects; their text is also in `warnings`)
    lint: list = field(default_factory=list)


@dataclass
class AqUnit:
    """A definite program compiled for active queries with transformation `mode` (a pass of
    `ACTIVE_QUERY_PIPELINE` names the mode it implements)."""

    program: definite.Program
    mode: str = "tabled"
    subsumption: bool = False   # tabled: reuse the table of a subsuming sub-goal
    warnings: List[str] = field(default_factory=list)
