"""The run animation (mirl.viz.animation): a GIF of one run with the frames its span and
max_frames give, for a run where L went, a timeout and a physics-world run."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from mirl.experiments.episode import run_episode
from mirl.experiments.options import RunProtocol
from mirl.viz.animation import HOLD_SECONDS, animation_times, save_run_animation
from mirl.world.scenario import load_scenario

SHORT = RunProtocol(obs_steps=30, watch_until_seen=None)


@pytest.fixture(scope="module")
def boyd2():
    return load_scenario("boyd2")


def _frames(path):
    """(frame count, size, per-frame durations in ms) of a GIF."""
    with Image.open(path) as im:
        assert im.format == "GIF"
        durations = []
        for k in range(im.n_frames):
            im.seek(k)
            durations.append(im.info["duration"])
        return im.n_frames, im.size, durations


def test_detected_run_is_subsampled_and_ends_on_the_detection(boyd2, tmp_path):
    # random goes at once and is seen within a few steps: a cheap run with a detection
    result = run_episode(boyd2, "random", seed=3, protocol=SHORT)
    assert result.outcome == "detected" and result.go_time is not None
    times = animation_times(result, context=20, max_frames=8)
    assert len(times) == 8
    assert times[0] == result.go_time - 20 and times[-1] == result.end_time
    assert np.all(np.diff(times) > 0)

    path = save_run_animation(boyd2, result, tmp_path / "sub" / "run.gif", context=20, max_frames=8)
    assert path == tmp_path / "sub" / "run.gif"
    n, (width, height), durations = _frames(path)
    assert n == 8
    assert 200 < width < height < 1200  # boyd2 is a tall map
    assert path.stat().st_size < 200_000
    # 4 fps, with the outcome held before the GIF loops
    assert durations[:-1] == [250] * 7 and durations[-1] == 250 + HOLD_SECONDS * 1000

    again = save_run_animation(boyd2, result, tmp_path / "again.gif", context=20, max_frames=8)
    assert again.read_bytes() == path.read_bytes()  # the same result, the same file


def test_a_short_span_has_one_frame_a_step(boyd2, tmp_path):
    result = run_episode(boyd2, "random", seed=3, protocol=SHORT)
    span = result.end_time - (result.go_time - 3) + 1
    path = save_run_animation(boyd2, result, tmp_path / "run.gif", fps=2, context=3)
    n, _, durations = _frames(path)
    assert n == span
    assert durations[0] == 500


def test_timeout_run_animates_its_last_steps(boyd2, tmp_path):
    result = run_episode(
        boyd2, "oracle", seed=3, protocol=SHORT.replace(max_wait=5, go_rule="value")
    )
    assert result.outcome == "timeout" and result.go_time is None
    times = animation_times(result, context=6)
    assert list(times) == list(range(result.end_time - 6, result.end_time + 1))
    n, _, _ = _frames(save_run_animation(boyd2, result, tmp_path / "timeout.gif", context=6))
    assert n == 7


def test_bad_arguments_are_refused(boyd2, tmp_path):
    result = run_episode(boyd2, "random", seed=3, protocol=SHORT)
    with pytest.raises(ValueError, match="max_frames"):
        save_run_animation(boyd2, result, tmp_path / "x.gif", max_frames=1)
    with pytest.raises(ValueError, match="context"):
        save_run_animation(boyd2, result, tmp_path / "x.gif", context=-1)
    with pytest.raises(ValueError, match="fps"):
        save_run_animation(boyd2, result, tmp_path / "x.gif", fps=0)
    assert not (tmp_path / "x.gif").exists()


def test_physics_run_animates(boyd2, tmp_path):
    result = run_episode(boyd2, "random", seed=3, world="physics", protocol=SHORT)
    assert result.extras is not None
    path = save_run_animation(boyd2, result, tmp_path / "physics.gif", context=4, max_frames=5)
    n, _, _ = _frames(path)
    assert n == len(animation_times(result, context=4, max_frames=5)) > 1
