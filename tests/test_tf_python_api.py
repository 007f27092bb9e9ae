"""Engine.tf_lookup: the tf library called with its arguments as data gives what the same
lookup through Engine.query gives, and tf2's failures as TfLookupError."""
from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from retalisc.driver.engine import Engine, TfLookupError, TfTransform


def _message(parent: str, child: str, secs: int, x: float, qz: float, qw: float) -> str:
    return ("tf2_msgs__0__TFMessage([geometry_msgs__0__TransformStamped("
            f"std_msgs__0__Header([{secs},0],'{parent}'),'{child}',"
            f"geometry_msgs__0__Transform(geometry_msgs__0__Vector3({x!r},0.5,0.0),"
            f"geometry_msgs__0__Quaternion(0.0,0.0,{qz!r},{qw!r})))])")


@pytest.fixture(scope="module")
def engine():
    with Engine.from_source("unused(X) <- tf_api_input(X).\n", "tf_api.rtl") as engine:
        for secs in (1, 2, 3):
            engine.feed(_message("odom", "base", secs, float(secs), 0.0, 1.0), secs)
            engine.feed(_message("base", "camera", secs, 0.1, 0.38268343236508984, 0.9238795325119648), secs)
        yield engine


def _via_query(engine, target, source, time_text):
    answer = engine.query(f"tf_lookup('{target}', '{source}', {time_text}, P, S, R)")
    return answer


@settings(max_examples=40, deadline=None)
@given(st.integers(min_value=1_000_000_000, max_value=3_000_000_000),
       st.sampled_from([("odom", "camera"), ("camera", "odom"), ("base", "camera"), ("odom", "base")]))
def test_equals_the_lookup_through_query(engine, ns, frames):
    target, source = frames
    typed = engine.tf_lookup(target, source, ("ns", ns))
    answer = _via_query(engine, target, source, f"ns({ns})")
    assert answer["R"] == "ok"
    pose = [typed.translation, typed.rotation]
    assert repr([list(pose[0]), list(pose[1])]).replace(" ", "") == answer["P"]
    assert f"[{typed.stamp[0]},{typed.stamp[1]}]" == answer["S"]


def test_time_forms(engine):
    latest = engine.tf_lookup("odom", "camera")
    assert isinstance(latest, TfTransform) and latest.stamp == (3, 0)
    assert engine.tf_lookup("odom", "camera", 0) == latest
    assert engine.tf_lookup("odom", "base", 2.5) == engine.tf_lookup("odom", "base", (2, 500_000_000))
    assert engine.tf_lookup("odom", "base", 2.5).translation[0] == pytest.approx(2.5)


def test_failures_are_tf2s_reasons(engine):
    with pytest.raises(TfLookupError) as unknown:
        engine.tf_lookup("odom", "nowhere")
    assert unknown.value.kind == "unknown_frame" and unknown.value.reason == "unknown_frame(nowhere)"
    with pytest.raises(TfLookupError) as future:
        engine.tf_lookup("odom", "base", 10)
    assert future.value.kind == "extrapolation"
    assert future.value.reason == _via_query(engine, "odom", "base", "10")["R"]


def test_arguments_are_data(engine):
    # a frame id that reads as goal text is only a frame id
    with pytest.raises(TfLookupError) as error:
        engine.tf_lookup("odom", "x'), halt, ('")
    assert error.value.kind == "unknown_frame"
    with pytest.raises(TypeError):
        engine.tf_lookup("odom", 3)
    with pytest.raises(ValueError):
        engine.tf_lookup("odom", "base", "soon")
