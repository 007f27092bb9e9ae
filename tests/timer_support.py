"""Helpers of the tests of timers, absences and sliding aggregates: one Engine per program,
made the active one and reset before each test."""


def outputs(engine, batch):
    """Feed a batch; the outputs as (event, start, end, op)."""
    return [(o.event, o.start, o.end, o.op) for o in engine.feed_batch(batch)]


def fresh(engine, max_delay="1", flush="false", horizon="auto"):
    """The engine, active, with nothing seen and the given flags (flags belong to the process)."""
    engine.activate()           # one program per process: another test may have loaded its own
    engine.clear()
    engine.set_flag("max_delay", max_delay)
    engine.set_flag("flush_timers", flush)
    engine.set_flag("retraction_horizon", horizon)
    return engine
