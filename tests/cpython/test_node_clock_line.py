# `acomm node` says when its wall clock's source changes: one line when a
# modem first tells the time, none while it stays the same.
from acomm.node import Node
from acomm.wallclock import MIN_S, WallClock
from acomm_cpython.cli.node import _EPOCH_2020, _clock_lines


class Out:
    def __init__(self):
        self.lines = []

    def emit(self, d):
        self.lines.append(d)


def test_a_line_when_the_source_changes():
    t = [0]
    wc = WallClock(lambda: _EPOCH_2020 + MIN_S, lambda: t[0], epoch_s=_EPOCH_2020)
    node = Node("n", 1, lambda: t[0], wallclock=wc)
    out = Out()
    step = _clock_lines(node, out)
    step(0)
    assert out.lines == [] and wc.wall() == _EPOCH_2020 + MIN_S
    wc.fix(0, "iridium", MIN_S + 100, 0, 500)
    step(10)
    step(20)
    assert out.lines == [{"event": "clock", "source": "iridium", "text": "wall clock from iridium (+-500 ms)"}]
    assert wc.wall() == _EPOCH_2020 + MIN_S + 100
