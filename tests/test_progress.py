"""The progress line (pmpm.solver.progress): its rate and ETA follow the run's recent
steps, not the average since the start, and it shows the step the run takes."""
import io
import re

import pytest

from pmpm.solver import progress as P


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def perf_counter(self):
        return self.now


def lines_of(stream):
    return [line for line in stream.getvalue().splitlines() if line.startswith("step")]


def field(line, pattern):
    return float(re.search(pattern, line).group(1))


@pytest.fixture
def clock(monkeypatch):
    fake = FakeClock()
    monkeypatch.setattr(P, "clock", fake)
    monkeypatch.setattr(P, "on_terminal", lambda stream: False)
    return fake


def test_rate_and_eta_follow_a_run_that_slows_down(clock):
    """100 s of wall at 1e6 particle-steps/s covering half the run, then ten times
    slower: the line at 55 % shows the slow rate and the ETA the slow rate gives (the
    average since the start would show 5.5e5 and about 82 s)."""
    stream = io.StringIO()
    progress = P.Progress(1.0, stream=stream)
    t = work = step = 0
    for _ in range(1000):                       # 0.1 s a step, 5e-4 of the run a step
        clock.now += 0.1
        t, work, step = t + 5e-4, work + 1e5, step + 1
        progress.update(step, t, 5e-4, work)
    for _ in range(1000):                       # ten times slower
        clock.now += 0.1
        t, work, step = t + 5e-5, work + 1e4, step + 1
        progress.update(step, t, 5e-5, work)
    line = lines_of(stream)[-1]
    assert field(line, r"(\d+\.\d)%") == 55.0
    assert field(line, r"([\d.]+) M particle-steps/s") == pytest.approx(0.10, abs=0.005)
    assert field(line, r"ETA\s+([\d.]+) s") == pytest.approx(0.45 / 5e-4, rel=0.01)
    assert field(line, r"dt ([\d.e+-]+)") == pytest.approx(5e-5)


def test_a_restart_measures_from_where_it_continues(clock):
    stream = io.StringIO()
    progress = P.Progress(1.0, stream=stream)
    clock.now = 50.0
    progress.start(0.5, 7e7)                    # the checkpoint's time and work
    for k in range(1, 101):
        clock.now += 0.1
        progress.update(k, 0.5 + k * 5e-4, 5e-4, 7e7 + k * 1e5)
    line = lines_of(stream)[-1]
    assert field(line, r"([\d.]+) M particle-steps/s") == pytest.approx(1.0, rel=1e-6)
    assert field(line, r"ETA\s+([\d.]+) s") == pytest.approx(0.45 / 5e-3, rel=1e-6)


def test_a_restart_waits_for_its_next_mark(clock):
    """Restarted at 13.6 %, the first line comes at 15 %, with the rate of the steps
    since the restart (before, a line came at once, its rate over no steps and its
    energy balance at zero)."""
    stream = io.StringIO()
    progress = P.Progress(1.0, stream=stream)
    progress.start(0.136, 7e7)
    clock.now += 0.1
    progress.update(1, 0.1365, 5e-4, 7e7 + 1e5, energy_growth=-0.027)
    assert lines_of(stream) == []
    for k in range(2, 40):
        clock.now += 0.1
        progress.update(k, 0.136 + k * 5e-4, 5e-4, 7e7 + k * 1e5, energy_growth=-0.027)
    first = lines_of(stream)[0]
    assert field(first, r"(\d+\.\d)%") == 15.0
    assert field(first, r"energy\s+([+-][\d.]+)%") == -2.7


def test_a_mesh_run_shows_its_element_steps(clock):
    """An FEM run counts element-steps: the line shows their rate beside the few
    particles' (a mesh of 3e5 elements at 0.8 steps a second: 0.24 M element-steps/s);
    a particle run's line has no element field."""
    stream = io.StringIO()
    progress = P.Progress(1.0, stream=stream)
    for k in range(1, 201):
        clock.now += 1.25
        progress.update(k, k * 5e-4, 5e-4, k * 5e3, elements=k * 3e5)
    line = lines_of(stream)[-1]
    assert field(line, r"([\d.]+) M element-steps/s") == pytest.approx(0.24, abs=0.005)
    assert field(line, r"([\d.]+) M particle-steps/s") == pytest.approx(0.0, abs=0.005)
    plain = io.StringIO()
    progress = P.Progress(1.0, stream=plain)
    for k in range(1, 201):
        clock.now += 1.25
        progress.update(k, k * 5e-4, 5e-4, k * 5e3)
    assert "element-steps" not in lines_of(plain)[-1]


def test_a_slow_block_is_announced_and_a_quick_one_is_not():
    import time
    stream = io.StringIO()
    with P.SlowNotice("compiling the kernels", after=0.05, stream=stream):
        time.sleep(0.3)
    lines = stream.getvalue().splitlines()
    assert lines[0] == "pmpm: compiling the kernels ..."
    assert re.fullmatch(r"pmpm: done in \d+ s", lines[1])
    quick = io.StringIO()
    with P.SlowNotice("compiling the kernels", after=5.0, stream=quick):
        pass
    with P.SlowNotice("compiling the kernels", enabled=False, after=0.0, stream=quick):
        time.sleep(0.1)
    assert quick.getvalue() == ""
