"""The simulated environment of examples/robapl_nao: NAO's external actions, by name. A walk or
a grasp takes time: the action answers later with the event action_result(Handle, Value)."""

#: seconds each long action takes
DURATIONS = {"move_to": 5.0, "pick_up": 1.0, "put_down": 1.0}


def register(actions):
    def say(person, text, context):
        return "said"

    def press(button, context):
        return "pressed"

    def recognise_face(camera, context):
        return "alice"

    def long_action(name):
        def action(*args, context):
            from retalisc.robapl.executor import PENDING
            from retalisc.robapl.terms import Atom, Compound
            context.emit(Compound("action_result", (context.handle, Atom("done"))), DURATIONS[name])
            return PENDING
        return action

    actions.register("say", say)
    actions.register("press", press)
    actions.register("recognise_face", recognise_face)
    for name in DURATIONS:
        actions.register(name, long_action(name))
