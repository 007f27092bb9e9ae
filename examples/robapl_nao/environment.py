"""The simulated environment of examples/robapl_nao: NAO's external actions, by name. A walk, a
turn of the head or a grasp takes time: the action answers later with the event
action_result(Handle, Value). The drug box (T2) holds two pills of drug A at the start of day 0,
and Mori takes one every day at 10 am: the count its picture gives depends on the clock only."""

#: seconds each long action takes
DURATIONS = {"move_to": 5.0, "pick_up": 1.0, "put_down": 1.0, "orient_head": 1.0, "hand_over": 1.0}
DAY = 86400.0
PILLS_AT_START = 2
PILL_TIME = 10 * 3600.0


def spoken(words) -> str:
    """What NAO says for a say/2 argument: a text as it is, on(Place) as "On the Place"."""
    if isinstance(words, dict) and list(words) == ["on"]:
        return "On the " + " ".join(str(part) for part in words["on"]).replace("_", " ")
    return str(words)


def pills_left(time: float) -> int:
    """The red pills in the white box at `time` (seconds from day 0's midnight)."""
    taken = 0 if time < PILL_TIME else int((time - PILL_TIME) // DAY) + 1
    return max(0, PILLS_AT_START - taken)


def register(actions):
    def say(person, words, context):
        return spoken(words)

    def press(button, context):
        return "pressed"

    def recognise_face(camera, context):
        return "alice"

    def take_picture(camera, context):
        return f"picture_{int(context.time)}"

    def count_pills(picture, colour, box, context):
        return pills_left(context.time) if (colour, box) == ("red", "white_box") else 0

    def send_email(to, text, context):
        return "sent"

    def long_action(name):
        def action(*args, context):
            from retalisc.robapl.executor import PENDING
            from retalisc.robapl.terms import Atom, Compound
            context.emit(Compound("action_result", (context.handle, Atom("done"))), DURATIONS[name])
            return PENDING
        return action

    for name, action in (("say", say), ("press", press), ("recognise_face", recognise_face),
                         ("take_picture", take_picture), ("count_pills", count_pills), ("send_email", send_email)):
        actions.register(name, action)
    for name in DURATIONS:
        actions.register(name, long_action(name))
