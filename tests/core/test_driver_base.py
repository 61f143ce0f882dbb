# The command slot and the configuration's retry rule that the four acoustic
# drivers share (acomm.drivers.base), on a toy modem that answers "OK" lines:
# a configuration that keeps failing says EV_DRIVER_DOWN once per outage and
# starts over only after retry_ms; commands unanswered while up lead to a
# probe, and down_after of them in a row to a lost modem.
from acomm.drivers.base import IDLE, AcousticDriver, ConfigSequence, SlotBase
from acomm.events import EV_DRIVER_DOWN, EV_DRIVER_UP


class ToyConfig(ConfigSequence):
    def __init__(self, driver, retry_ms, steps):
        ConfigSequence.__init__(self, driver, retry_ms)
        self.steps = steps
        self.i = 0

    def first(self):
        self.i = 0

    def step(self, now):
        if self.i >= self.steps:
            self.done(now)
            return
        self.d.command(now, "CFG%d" % self.i)


class ToySlot(SlotBase):
    def poll(self, now):
        return False


class ToyReader:
    def __init__(self, sink):
        self.sink = sink

    def feed(self, data):
        for line in data.split(b"\n"):
            if line:
                self.sink.on_line(line)


class ToyModem(AcousticDriver):
    def __init__(self, steps=1, down_after=3, retry_ms=1000, cmd_timeout_ms=100):
        AcousticDriver.__init__(self)
        self.down_after = down_after
        self.alive_period_ms = 0
        self.cmd_timeout_ms = cmd_timeout_ms
        self.stats = {"cmd_timeouts": 0}
        self.config = ToyConfig(self, retry_ms, steps)
        self.slot = ToySlot(self, 8)
        self._reader = ToyReader(self)

    def command(self, now, text):
        self._out.extend(text.encode() + b"\n")
        self._await(now, text, self.cmd_timeout_ms)

    def ask(self, now):
        self.command(now, "ASK")

    def on_line(self, line):
        now = self._now
        if not self.cmd:
            return
        self.cmd = 0
        self._heard_from(now)
        if self._state != 1:  # S_CONFIG
            return
        if line == b"OK":
            self.config.i += 1
        else:
            self.config.failed(now, "refused")

    def _next_command(self, now):
        if self._probe_due(now):
            self.command(now, "PROBE")

    def _unanswered(self, now, what):
        if self._state == 1:  # S_CONFIG
            self.config.failed(now, "no answer to " + what)

    def _slot_gave_up(self, now):
        pass

    def lost(self, now, reason):
        self._went_down(reason)
        self._set_up_again(now)


def up_modem(**kw):
    d = ToyModem(**kw)
    d.poll(0)
    assert d.take_output() == b"CFG0\n"
    d.feed(10, b"OK\n")
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.ready(10) and d.slot.state == IDLE
    return d


def test_a_failing_configuration_says_down_once_per_outage_and_retries_after_retry_ms():
    d = ToyModem(down_after=2, retry_ms=1000)
    d.poll(0)
    assert d.take_output() == b"CFG0\n"
    d.poll(100)  # unanswered: start over, but only after retry_ms
    assert d.take_output() == b"" and d.take_events() == [] and d.config.fails == 1
    d.poll(1099)
    assert d.take_output() == b""
    d.poll(1100)
    assert d.take_output() == b"CFG0\n"
    d.poll(1200)  # the second failure in a row: down, once
    assert d.take_events() == [(EV_DRIVER_DOWN, "no answer to CFG0")]
    assert d.config.problem == "no answer to CFG0" and d.stats["cmd_timeouts"] == 2
    d.poll(2200)
    d.feed(2210, b"ERROR\n")  # refused: a failure like silence, and not said again
    assert d.take_events() == [] and d.config.fails == 3 and d.config.problem == "refused"
    assert not d.ready(2210)
    d.poll(3210)
    assert d.take_output() == b"CFG0\nCFG0\n"
    d.feed(3220, b"OK\n")
    assert d.take_events() == [(EV_DRIVER_UP,)] and d.ready(3220)
    assert d.config.fails == 0 and d.config.problem is None


def test_the_next_outage_is_said_again():
    d = up_modem(down_after=1)
    d.lost(20, "modem rebooted")
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem rebooted")] and not d.ready(20)
    d.poll(20)
    assert d.take_output() == b"CFG0\n"
    d.poll(120)  # the configuration fails too: the outage was already said
    assert d.take_events() == []
    d.poll(1120)
    d.feed(1130, b"OK\n")
    assert d.take_events() == [(EV_DRIVER_UP,)]
    d.poll(1130)
    d.ask(1130)
    d.poll(1230)  # down_after = 1: the first unanswered command loses the modem
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem not answering")]


def test_unanswered_commands_bring_a_probe_then_lose_the_modem():
    d = up_modem(down_after=2)
    d.ask(20)
    assert d.take_output() == b"ASK\n"
    d.poll(119)
    assert d.take_output() == b"" and d.stats["cmd_timeouts"] == 0
    d.poll(120)  # one unanswered: ask whether the modem is still there
    assert d.take_output() == b"PROBE\n" and d.take_events() == [] and d.ready(120)
    d.feed(130, b"OK\n")  # it is: the silence count starts again
    d.ask(140)
    d.poll(240)
    assert d.take_output() == b"ASK\nPROBE\n" and d.take_events() == []
    d.poll(340)  # the probe unanswered too: two in a row
    assert d.take_events() == [(EV_DRIVER_DOWN, "modem not answering")]
    assert d.take_output() == b"CFG0\n" and not d.ready(340) and d.stats["cmd_timeouts"] == 3
