"""The pass pipelines: the whole compilation of each kind of program, in order, one list each.

A pass is a module with a `name` and `run(unit) -> unit`; it changes dataclasses and terms only
(no parsing, no Prolog text). To add a pass, write its module and put it in the list at its
place: `retalisc.compiler` runs the lists, and `retalisc compile --dump-after NAME` shows the
unit after any pass.
"""
from __future__ import annotations

from typing import Callable, List, Optional, TypeVar

from . import (added_rules, apply_rule_windows, aq_join_order, aq_naive, aq_normalise, aq_optimized, aq_program,
               aq_tabled, binarize, collect_settings, edbc, lint, loadable, push_conditions, slr_goal_sets,
               slr_stream_histories, slr_time_terms, validate)

#: Event programs (`.rtl`, read by `frontend/program.py`), rendered by `backends/prolog/render.py`.
EVENT_PIPELINE = [slr_time_terms, slr_stream_histories, slr_goal_sets, validate, collect_settings, apply_rule_windows, push_conditions, binarize, edbc,
                  loadable, lint]

#: Event rules added to a running program (`retalisc compile-rules`, `Engine.add_rules`): checked
#: and named, then compiled like the rules of a program (without `lint`: what they call is
#: defined by the running program, which this compilation does not see).
ADDED_RULES_PIPELINE = [added_rules] + [p for p in EVENT_PIPELINE if p is not lint]

#: Definite programs for active queries (read by `frontend/definite.py`), rendered by
#: `backends/prolog/aq_backend.py`. A pass with a `mode` attribute is one transformation
#: (thesis 6.4-6.6) and runs only when that mode is asked for; see `active_query_passes`.
ACTIVE_QUERY_PIPELINE = [aq_normalise, aq_program, aq_join_order, aq_naive, aq_optimized, aq_tabled]

#: The active-query transformations, in the order of the list.
AQ_MODES = [p.mode for p in ACTIVE_QUERY_PIPELINE if getattr(p, "mode", None)]

#: Every pass `retalisc compile` can run, for `--dump-after`.
PASS_NAMES = list(dict.fromkeys(p.name for p in EVENT_PIPELINE + ACTIVE_QUERY_PIPELINE))

U = TypeVar("U")


def active_query_passes(mode: str) -> list:
    """The passes that compile a definite program with transformation `mode`."""
    if mode not in AQ_MODES:
        raise ValueError(f"unknown active-query mode {mode!r} (expected one of {', '.join(AQ_MODES)})")
    return [p for p in ACTIVE_QUERY_PIPELINE if getattr(p, "mode", mode) == mode]


def run_pipeline(unit: U, passes: Optional[List] = None,
                 after_pass: Optional[Callable[[str, U], None]] = None) -> U:
    """Run `passes` (default: the event pipeline) in order; `after_pass(name, unit)` sees the
    unit after each one."""
    for compiler_pass in EVENT_PIPELINE if passes is None else passes:
        unit = compiler_pass.run(unit)
        if after_pass is not None:
            after_pass(compiler_pass.name, unit)
    return unit
