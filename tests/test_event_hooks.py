"""The hooks of rtl_event/3 and its siblings (prolog_runtime/rtl_ele.pl): for every event given
to the program, input, derived or retracted, each hook of the event's type runs once, then each
hook of every type once, in the order they were added, with Op `add` or `retract`; hooks of
other types do not run. Input events come through the line loop's blocks of plain event lines
(rtl_block_input/3), the road a file's lines take. The oracle is the list of events and ops,
computed here from the stream and the program's one rule."""
import subprocess

PROGRAM = "pair(X, Y) <- a(X) seq b(Y).\n"

HOOKS = r"""
:- dynamic seen/1.
typed(Tag, Event, _, End, Op) :- assertz(seen(typed(Tag, Event, End, Op))).
every(Tag, Event, _, End, Op) :- assertz(seen(every(Tag, Event, End, Op))).

main :-
    rtl_add_type_output_hook(a(_), user:typed(ta)),
    rtl_add_type_output_hook(pair(_, _), user:typed(tp)),
    rtl_add_output_hook(user:every(e1)),
    rtl_add_output_hook(user:every(e2)),
    rtl_input_block(( rtl_block_input(a(1), 1, 1), rtl_block_input(c(9), 2, 2),
                      rtl_block_input(b(2), 3, 3) )),
    rtl_input(retract, a(1), 1, 1),
    forall(seen(S), ( write_canonical(S), nl )).
"""


def test_each_hook_runs_once_per_event_in_order(tmp_path, swipl):
    from retalisc.compiler import compile_source

    program = tmp_path / "p.pl"
    program.write_text(compile_source(PROGRAM, "p.rtl", output_name="p.pl").prolog)
    script = tmp_path / "hooks.pl"
    script.write_text(":- create_prolog_flag(retalis_embedded, true, []).\n"
                      f":- consult('{program}').\n"
                      ":- use_module(retalis_runtime(rtl_raise)).\n:- use_module(retalis_runtime(rtl_ele)).\n" + HOOKS)
    done = subprocess.run([swipl, "-g", "main", "-t", "halt", str(script)],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    expected = []
    for event, end, op in [("a(1)", 1, "add"), ("c(9)", 2, "add"), ("b(2)", 3, "add"),
                           ("pair(1,2)", 3, "add"), ("a(1)", 1, "retract"), ("pair(1,2)", 3, "retract")]:
        if event.startswith("a("):
            expected.append(f"typed(ta,{event},{end},{op})")
        if event.startswith("pair("):
            expected.append(f"typed(tp,{event},{end},{op})")
        expected += [f"every(e1,{event},{end},{op})", f"every(e2,{event},{end},{op})"]
    hooks = [line for line in done.stdout.splitlines() if not line.startswith("{")]    # (the output lines)
    assert hooks == expected
