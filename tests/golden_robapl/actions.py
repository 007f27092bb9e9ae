"""The external actions of the RobAPL golden cases: `act(X)` answers at once, `long(X, Seconds)`
answers later with the event action_result(Handle, done), `broken(X)` fails at once."""


def register(actions):
    from retalisc.robapl.executor import PENDING, ActionFailed
    from retalisc.robapl.terms import Atom, Compound

    def act(*args, context):
        return "done"

    def long(thing, seconds, context):
        context.emit(Compound("action_result", (context.handle, Atom("done"))), float(seconds))
        return PENDING

    def broken(*args, context):
        raise ActionFailed("broken")

    actions.register("act", act)
    actions.register("long", long)
    actions.register("broken", broken)
