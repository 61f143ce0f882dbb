# The ocean around a board running on an emulated Raspberry Pi Pico
# (acomm_cpython.board.picoboard), for tests that put faults on the board's lines:
# an acomm_sim World in this process (the board's own modems, and its peers'
# nodes with their modems) whose clock follows the board's simulated clock,
# and a cable from each of the board's UARTs (the runner's TCP port) to
# whatever the test puts at its far end, which it can swap while the board
# runs:
#
#   plug()         the board's emulated modem (SeaTrac, Iridium...);
#   unplug()       nothing: what the board sends is read and dropped, and
#                  not a byte comes back (the modem emulator keeps living
#                  in the World, deaf to the board);
#   noise(source, rate=1.0)  source(n) -> up to n bytes of the test's
#                  choosing (garbage), sent at `rate` times what the line
#                  can carry (1.0: back to back at its baud).
#
#   ocean = PicoOcean(board, cfg, peers={"diver": "seatrac", "shore": "iridium"}, via={"diver": "shore"})
#   ocean.run_until(lambda: ..., sim_ms=60000)   # pumps bytes and time
#   ocean.peer("diver").send(...)                 # a peer's Transport
#   ocean.console.text                            # the board's USB output
#   ocean.cables[1].unplug()
#
# Time: the World runs in this thread; each pump() reads the board's clock
# (the runner's ctl port) and runs the World up to it, so both sides agree
# on what a second is whatever speed the emulator runs at (speed_cap=0
# lets an idle board run ahead of wall time; the modems then keep up with
# it instead of answering late in the board's eyes). The runner paces what
# goes to the board at the line's baud in its own simulated time; bytes
# for the board are handed over as the World produces them. CPython only.

import socket
import time

from acomm_sim.boardsim import add_peers, fast_options
from acomm_sim.world import World

_CHUNK = 65536


def _connect(board, name):
    s = socket.create_connection((board.host, board.ports[name]), timeout=10)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    s.setblocking(False)
    return s


def _recv(sock):
    try:
        data = sock.recv(_CHUNK)
    except (BlockingIOError, InterruptedError):
        return b""
    if not data:
        raise ConnectionError("the RP2040 runner closed a port")
    return data


def _send(sock, data):
    # the runner buffers up to 64 KiB per line and paces it in: a short
    # blocking wait for the socket is enough here
    view = memoryview(data)
    end = time.monotonic() + 10
    while view:
        try:
            n = sock.send(view)
            view = view[n:]
        except (BlockingIOError, InterruptedError):
            if time.monotonic() > end:
                raise ConnectionError("the RP2040 runner does not take a line's bytes")
            time.sleep(0.001)


class Console:
    """The board's USB CDC output (its REPL and print()s), read from the runner's USB port.

    Connecting replaces any other client of that port (a socat pty)."""

    def __init__(self, board):
        self.sock = _connect(board, "usb")
        self.raw = bytearray()

    def pump(self):
        while True:
            data = _recv(self.sock)
            if not data:
                return
            self.raw += data

    @property
    def text(self):
        return self.raw.decode(errors="replace")

    def count(self, marker):
        return self.raw.count(marker)

    def send(self, data):
        """Bytes typed at the board's REPL (b"\\x03": Ctrl-C)."""
        _send(self.sock, data)

    def close(self):
        self.sock.close()


class Cable:
    """One of the board's UARTs and what is at its other end (see the module's comment)."""

    MODEM, UNPLUGGED, NOISE = "modem", "unplugged", "noise"

    def __init__(self, board, uart, baud, ends):
        self.uart = uart
        self.baud = baud
        self.emu, self.host_end = ends[0], ends[1]
        self.sock = _connect(board, "uart%d" % uart)
        self.state = self.MODEM
        self._source = None
        self._rate = 1.0
        self._owed = 0.0  # bytes of noise the line could have carried, not sent yet
        self.from_board = 0  # bytes the board wrote on this UART
        self.dropped = 0  # of those, bytes that reached no modem (unplugged, noise)
        self.noise_sent = 0
        self.log = []  # (sim ms, "board" | "modem", bytes) while logging
        self.logging = False

    def plug(self):
        self.host_end.read()  # what the modem said into a loose cable is gone
        self.state = self.MODEM

    def unplug(self):
        self.state = self.UNPLUGGED

    def noise(self, source, rate=1.0):
        """source(n) -> at most n bytes: what the line carries, at rate x its baud, until plug() or unplug()."""
        self._source = source
        self._rate = rate
        self._owed = 0.0
        self.state = self.NOISE

    def _from_board(self, now):
        data = _recv(self.sock)
        while data:
            self.from_board += len(data)
            if self.logging:
                self.log.append((now, "board", bytes(data)))
            if self.state == self.MODEM:
                self.host_end.write(data)
            else:
                self.dropped += len(data)
            data = _recv(self.sock)

    def _to_board(self, now, elapsed_ms):
        out = self.host_end.read()
        if self.state == self.MODEM:
            if out:
                if self.logging:
                    self.log.append((now, "modem", bytes(out)))
                _send(self.sock, out)
        elif self.state == self.NOISE:
            # 10 bits a character: no faster than the line, or the runner's
            # queue would only grow (and drop)
            self._owed = min(self._owed + elapsed_ms * self._rate * self.baud / 10000.0, 4096)
            n = int(self._owed)
            if n:
                data = bytes(self._source(n))[:n]
                self._owed -= n
                if data:
                    self.noise_sent += len(data)
                    _send(self.sock, data)

    def close(self):
        self.sock.close()


class PicoOcean:
    def __init__(self, board, cfg, peers=None, via=None, seed=1, emu_opts=None, unplugged=()):
        """board: a running PicoBoard; cfg: the board's checked config (acomm_mp.boardconfig.check).
        peers/via: as acomm_sim.boardsim.add_peers (each peer a node with a Transport here).
        emu_opts: {modem: options} for the board's own modems, over boardsim's fast options.
        unplugged: names of links whose cable starts unplugged (what the board
        wrote before the ocean was made, held by the runner, is dropped too)."""
        self.board = board
        self.cfg = cfg
        self.w = World(seed=seed)
        self.wall = lambda: 1000000 + self.w.now() // 1000
        self.cables = []
        for i, lk in enumerate(cfg["links"]):
            opts = dict(fast_options(lk["modem"])[1])
            opts.update((emu_opts or {}).get(lk["modem"], {}))
            ends = self.w.add_loose(self.w.modem_ends(lk["modem"], lk["address"], opts,
                                                      (0.0, 0.0, 0.0) if i == 0 else None))
            self.cables.append(Cable(board, lk["uart"], lk["baud"], ends))
            if lk["name"] in unplugged:
                self.cables[-1].unplug()
        self.peers = add_peers(self.w, cfg, peers or {}, via, self.wall)
        self.console = Console(board)
        self.sim0 = board.sim_ms()
        self._last = 0.0
        self.now = 0.0  # the board's time at the last pump()
        self.pumps = 0

    def cable(self, link_name):
        for lk, c in zip(self.cfg["links"], self.cables):
            if lk["name"] == link_name:
                return c
        raise KeyError(link_name)

    def peer(self, name):
        """A peer's Transport."""
        return self.peers[name][1]

    def events(self, name):
        """A peer node's events so far."""
        return self.peers[name][0].events

    def sim_ms(self):
        """The board's simulated time since this ocean was made."""
        return self.board.sim_ms() - self.sim0

    def pump(self):
        """Moves the board's bytes to the modems, the World to the board's time, and the modems' bytes back."""
        now = self.now = self.sim_ms()
        wnow = self.w.now()
        for c in self.cables:
            c._from_board(wnow)
        ahead = int(now) - wnow
        if ahead > 0:
            self.w.run(ahead)
        elapsed = now - self._last
        self._last = now
        for c in self.cables:
            c._to_board(self.w.now(), elapsed)
        self.console.pump()
        self.pumps += 1

    def run_until(self, cond, sim_ms=None, wall_s=120, poll_s=0.01):
        """Pumps until cond() is true (-> True), or sim_ms of the board's time or wall_s have passed (-> False)."""
        end_sim = None if sim_ms is None else self.sim_ms() + sim_ms
        end_wall = time.monotonic() + wall_s
        while True:
            self.pump()
            if cond is not None and cond():
                return True
            if end_sim is not None and self.now >= end_sim:
                return False
            if time.monotonic() > end_wall:
                return False
            time.sleep(poll_s)

    def run_for(self, sim_ms, wall_s=300):
        """Pumps for sim_ms of the board's time (-> False if wall_s ran out first)."""
        end = self.sim_ms() + sim_ms
        return self.run_until(lambda: self.now >= end, wall_s=wall_s)

    def close(self):
        for c in self.cables:
            c.close()
        self.console.close()
