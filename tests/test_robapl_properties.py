"""Properties of the RobAPL executor on random event sequences (hypothesis), over the agents of
the golden cases and the NAO use case: a node is in one state at a time (each transition leaves
the state the node is in, to a state of the table); a resource is never over-allocated (after
every micro step); the same event sequence gives the same trace; a node that fails or is
pre-empted leaves Failing only after its descendants and its wind-down nodes have finished."""
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.robapl.executor import INACTIVE, FINISHED, STATES, Executor
from retalisc.robapl.runner import load_actions, read_event_lines
from retalisc.robapl.syntax import load_agent

ROOT = Path(__file__).resolve().parent.parent
GOLDEN = ROOT / "tests" / "golden_robapl"
NAO = ROOT / "examples" / "robapl_nao"
AGENTS = [(GOLDEN / name / "agent.apl", GOLDEN / name / "events.jsonl", GOLDEN / "actions.py")
          for name in ("preempt", "pause_resume", "resource_wait", "invariant", "finishing_fails", "resume_aborted",
                       "ancestor_skips", "abstract_goals")]
AGENTS.append((NAO / "nao.apl", NAO / "events.jsonl", NAO / "environment.py"))


class CheckedExecutor(Executor):
    """Checks the resource pool after every micro step."""

    def apply(self, transitions):
        super().apply(transitions)
        nodes = [node for plan in self.plans for node in plan.root.walk()]
        for name, capacity in self.pool.capacity.items():
            held = sum(node.held.get(name, 0) for node in nodes)
            assert self.pool.free[name] >= 0, f"{name} over-allocated: free {self.pool.free[name]}"
            assert abs(self.pool.free[name] + held - capacity) < 1e-9, f"{name}: free + held != capacity"


def vocabulary(events_file):
    return [term for _, term in read_event_lines(events_file.read_text()).events]


@st.composite
def scenarios(draw):
    agent_file, events_file, actions_file = draw(st.sampled_from(AGENTS))
    words = vocabulary(events_file)
    count = draw(st.integers(1, 12))
    times = sorted(draw(st.lists(st.integers(0, 120), min_size=count, max_size=count)))
    events = [(float(t), draw(st.sampled_from(words))) for t in times]
    return agent_file, actions_file, events


def run(agent_file, actions_file, events, executor=Executor):
    return executor(load_agent(agent_file), load_actions(str(actions_file))).run(events)


def check_one_state_at_a_time(trace):
    state = {}
    for record in trace:
        if "plan" in record:
            state[record["plan"]] = "waiting"
        if "to" not in record:
            continue
        assert record["to"] in STATES
        node = record["node"]
        assert state.get(node, INACTIVE) == record["from"], f"{node} left {record['from']} while {state.get(node)}"
        state[node] = record["to"]


def check_wind_down_before_parent(trace, agent_file):
    state = {}
    for record in trace:
        if "plan" in record:
            state[record["plan"]] = "waiting"
        if "to" not in record:
            continue
        node = record["node"]
        if record["from"] == "failing":
            inside = {n: s for n, s in state.items() if n.startswith(node + "/")}
            assert all(s in (INACTIVE, FINISHED) for s in inside.values()), \
                f"{node} left failing while {inside}"
        state[node] = record["to"]


@settings(max_examples=60, deadline=None)
@given(scenarios())
def test_properties(scenario):
    agent_file, actions_file, events = scenario
    trace = run(agent_file, actions_file, events, CheckedExecutor)
    check_one_state_at_a_time(trace)
    check_wind_down_before_parent(trace, agent_file)
    assert run(agent_file, actions_file, events) == trace


def test_preempted_plans_run_their_wind_down():
    """Whenever the NAO's trash plan is pre-empted while carrying, the trash is left on the floor
    (the on_preempt wind-down) before the plan ends, and only then does help start."""
    events = [(0.0, vocabulary(NAO / "events.jsonl")[0]), (8.0, vocabulary(NAO / "events.jsonl")[3])]
    trace = run(NAO / "nao.apl", NAO / "environment.py", events)
    order = [(r["action"] if "action" in r else r["node"], r.get("to")) for r in trace if "to" in r or "action" in r]
    assert order.index(("put_down(trash,floor)", None)) < order.index(("trash#1", "finished")) < \
        order.index(("help#1", "executing"))


# ---- random agents: random plan trees, conditions, resources and priorities ------------------

EVENTS = ["a", "b", "c", "d"]
CONDITION_NAMES = ["start", "end", "invariant", "preempt", "pause", "resume", "pre"]


@st.composite
def random_nodes(draw, depth, names):
    kind = draw(st.sampled_from(["external", "external", "belief_update", "list"] if depth < 3 else
                                ["external", "belief_update"]))
    name = f"n{next(names)}"
    attributes = []
    for condition in draw(st.lists(st.sampled_from(CONDITION_NAMES), max_size=2, unique=True)):
        event = draw(st.sampled_from(EVENTS))
        attributes.append(f"{condition}: {'not ' if condition == 'invariant' else ''}event({event})")
    if draw(st.booleans()):
        attributes.append(f"resources: <{draw(st.sampled_from(['r1', 'r2']))}, "
                          f"{draw(st.sampled_from(['using', 'blocking']))}, 1>")
    if kind == "belief_update":
        attributes.append(f"post: done({name})")
    text = f"{kind} {name}"
    if kind == "external":
        text += f": long({name}, {draw(st.integers(0, 5))})"
    if attributes:
        text += " [" + "; ".join(attributes) + "]"
    if kind == "list":
        children = draw(st.lists(random_nodes(depth + 1, names), min_size=1, max_size=3))
        for wind in draw(st.lists(st.sampled_from(["on_abort", "on_preempt", "on_pause", "on_resume"]),
                                  max_size=2, unique=True)):
            children.append(f"{wind} w{next(names)} {{ external x{next(names)}: act(w) }}")
        text += " { " + " ".join(children) + " }"
    return text


@st.composite
def random_agents(draw):
    import itertools
    names = itertools.count()
    rules = []
    for index, event in enumerate(draw(st.lists(st.sampled_from(EVENTS), min_size=1, max_size=3, unique=True))):
        priority = draw(st.integers(0, 3))
        children = draw(st.lists(random_nodes(1, names), min_size=1, max_size=3))
        rules.append(f"{event} <- true | list p{index} [priority: {priority}] {{ {' '.join(children)} }}")
    agent = "resources { r1: 1. r2: 2. }\nrules {\n" + "\n".join(rules) + "\n}\n"
    times = sorted(draw(st.lists(st.integers(0, 30), min_size=1, max_size=10)))
    events = [(float(t), draw(st.sampled_from(EVENTS))) for t in times]
    return agent, events


@settings(max_examples=80, deadline=None)
@given(random_agents())
def test_properties_of_random_agents(tmp_path_factory, scenario):
    from retalisc.robapl.syntax import parse_agent
    from retalisc.robapl.terms import Atom

    text, events = scenario
    agent_file = tmp_path_factory.mktemp("agent") / "agent.apl"
    agent_file.write_text(text)
    parse_agent(text)
    terms = [(t, Atom(e)) for t, e in events]
    trace = run(agent_file, GOLDEN / "actions.py", terms, CheckedExecutor)
    check_one_state_at_a_time(trace)
    check_wind_down_before_parent(trace, agent_file)
    assert run(agent_file, GOLDEN / "actions.py", terms) == trace


def test_one_event_does_not_pause_and_resume_a_node_for_ever(tmp_path):
    """Found by test_properties_of_random_agents: pause and resume on the same event had made
    Executing -> Pausing -> Paused -> Resuming -> Waiting -> Executing -> ... in one macro step."""
    agent_file = tmp_path / "agent.apl"
    agent_file.write_text("resources { r1: 1. }\nrules {\n"
                          "c <- true | list p1 { external n1: long(n1, 0) [pause: event(c); resume: event(c)] }\n}\n")
    from retalisc.robapl.terms import Atom

    trace = run(agent_file, GOLDEN / "actions.py", [(0.0, Atom("c")), (1.0, Atom("c")), (2.0, Atom("c"))])
    toggles = {}
    for record in trace:
        if record.get("to") in ("pausing", "resuming"):
            toggles.setdefault(record["node"], []).append((record["macro"], record["to"]))
    assert toggles["p1#1/n1"] == [(1, "pausing"), (3, "resuming")]
    for moves in toggles.values():
        macros = [macro for macro, _ in moves]
        assert len(macros) == len(set(macros))              # at most one of the two a macro step
