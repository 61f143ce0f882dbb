# The buoy on its own chip: boards/buoy_pico flashed with `acomm flash` onto
# an emulated Raspberry Pi Pico (acomm_cpython.board.picoboard, MicroPython's own
# RPI_PICO firmware) as onto a real one, between two emulated modems, with
# the diver's tablet program on a second emulated Pico. CPython only; used by
# `acomm bench board` and tests/cpython/test_buoy_on_pico.py.
#
#   diver Pico UART1 -- seatrac beacon 2 ~~ water ~~ beacon 1 -- UART0 buoy Pico
#   buoy Pico UART1 -- Iridium 9603 (IMEI ..001) ~~ gateway ~~ 9603 (..003) -- shore
#
# Every party is what a user runs: `acomm flash --reset` for both boards,
# `acomm emulate seatrac` (buoy's beacon, --peer 2 for the diver's) and
# `acomm emulate iridium --log` (buoy's modem, --peer 3 for shore's), and
# `acomm node` as shore on its modem. The cables are modemtaps.Bridge, which
# also reads the traffic as it passes.
#
# The diver is boards/diver_esp32s3 with its config mapped to the RP2040: its
# SeaTrac on UART1 GP4/GP5, arch armv6m, the watchdog at 8 s (the RP2040's
# tops out at 8.3 s: machine.WDT(timeout=10000) raises ValueError there), and
# its status report to shore (via the buoy, by its routes) every period_s.
#
# The run:
#  1. flash the buoy (timed; MicroPython's own firmware, acomm as .mpy) and
#     then the diver (on rp2040-full.uf2, acomm frozen in, when it is built:
#     only its main.py and config.py are copied); each starts its main.py;
#  2. once the buoy has acknowledged the diver's first report whole (its
#     completion SACK on UART0: the packet is in its store on flash), the
#     diver is switched off, so that the run follows that one packet;
#  3. the buoy tries shore acoustically first (free; no answer: it stalls
#     after three polls), then over Iridium. Once it has sent AT+SBDIX with
#     the diver's fragment in the modem's MO buffer, the buoy is power-cycled
#     (the runner's ctl reset) while the session runs: the modem, powered on
#     its own, completes it and the gateway has the message, but the buoy
#     never sees the result. Its boot is timed on the runner's clock, from
#     the reset to the ready line on USB;
#  4. the rebooted buoy finds the packet in its store and must not send it
#     again: its first round on a resumed lane is a bare poll, which shore
#     answers with the completion it remembers. The run waits until shore
#     has the packet and the buoy has read that completion after a poll of
#     its new life, reads the buoy's store file with mpremote as a user
#     would, and reads both modems' captures back for the figures.

import json
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time

from ..emulate import modemtaps as mt
from ..emulate.capture import read_capture
from ..board.picoboard import PicoBoard, PicoError, firmware, runner_available
from ..board.procs import die_with_parent

BUOY, DIVER, SHORE = 1, 2, 3
READY = {"buoy": b"acomm buoy: node 1", "diver": b"acomm diver: node 2"}
FLASH_TIMEOUT_S = 240
BOOT_TIMEOUT_S = 60


class ScenarioError(RuntimeError):
    pass


def missing():
    """None when the scenario can run here, else one line saying what is missing."""
    m = runner_available()
    if m:
        return m
    if firmware("rp2040-stock") is None:
        return ("no RP2040 firmware: build build/firmware/rp2040-stock.uf2 (make firmware) "
                "or set ACOMM_RP2040_FIRMWARE")
    return None


def _acomm():
    exe = os.path.join(os.path.dirname(sys.executable), "acomm")
    return [exe] if os.access(exe, os.X_OK) else [sys.executable, "-m", "acomm_cpython.cli"]


def diver_board(boards_dir, period_s):
    """boards/diver_esp32s3 mapped to an RP2040, as boards_dir/diver_pico; returns its checked config."""
    from ..board.boardfiles import board_path, load_config

    src = board_path("diver_esp32s3")
    g = {}
    with open(os.path.join(src, "config.py")) as f:
        exec(f.read(), g)
    # only what the chip changes; the rest is the diver's own configuration
    cfg = dict(g["CONFIG"], arch="armv6m", watchdog_ms=8000)
    cfg["links"] = [dict(lk, uart=1, tx=4, rx=5, baud=115200) for lk in cfg["links"]]
    cfg["station"] = dict(cfg["station"], report_to="shore", report_period_s=period_s)
    d = os.path.join(boards_dir, "diver_pico")
    os.makedirs(d, exist_ok=True)
    shutil.copy(os.path.join(src, "main.py"), os.path.join(d, "main.py"))
    with open(os.path.join(d, "config.py"), "w") as f:
        f.write("# boards/diver_esp32s3 on a Raspberry Pi Pico (acomm_cpython.bench.picobuoy)\nCONFIG = %r\n" % (cfg,))
    return load_config(d)


def flash_plans(period_s=5):
    """[(board, files, bytes)] of the run's two boards (buoy_pico, the diver's) as `acomm flash` stages them
    for the Pico (.mpy for armv6m), without a board: `acomm bench board --quick`."""
    from ..board.boardfiles import board_path, plan

    d = tempfile.mkdtemp(prefix="picobuoy-plan-")
    try:
        diver_board(d, period_s)
        out = []
        for name, bdir in (("buoy", board_path("buoy_pico")), ("diver", os.path.join(d, "diver_pico"))):
            entries = plan(bdir, "armv6m", stage_dir=os.path.join(d, "stage-" + name))
            out.append((name, len(entries), sum(e.size for e in entries)))
        return out
    finally:
        shutil.rmtree(d, ignore_errors=True)


class Run:
    """One run of the scenario; run() gives its figures and evidence as a dict."""

    def __init__(self, period_s=5, say=None):
        self.period_s = period_s
        self.say = say or (lambda s: None)
        self.dir = tempfile.mkdtemp(prefix="picobuoy-")
        self.procs = []
        self.closers = []
        self.cons = []  # the boards' Consoles
        self.lock = threading.Lock()
        self.session_at = self.result_at = None  # step 3's session: begun, its result back (monotonic s)
        self.reset_at = None  # when the buoy was reset (monotonic s)
        self.asked_from = None  # sky.order's length at the rebooted buoy's first AT+SBDIX
        self.sea = mt.SeatracLine(BUOY)
        self.sky = mt.IridiumLine()

    # -- the parties ------------------------------------------------------------------------
    def path(self, name):
        return os.path.join(self.dir, name)

    def start(self, args, name, lines=1):
        """A CLI process (its output in DIR/name.out); waits for its first `lines` lines."""
        out = open(self.path(name + ".out"), "w+")
        p = subprocess.Popen(_acomm() + args, stdin=subprocess.PIPE, stdout=out, stderr=subprocess.STDOUT,
                             text=True, preexec_fn=die_with_parent)
        self.procs.append((p, out))
        end = time.monotonic() + 30
        while True:
            with open(out.name) as f:
                text = f.read()
            if text.count("\n") >= lines:
                return p
            if p.poll() is not None or time.monotonic() > end:
                raise ScenarioError("%s did not start: %s" % (" ".join(args[:2]), text.strip()[-400:]))
            time.sleep(0.05)

    def tap(self, reader):
        def feed(to, data):
            with self.lock:
                reader.feed(to, data)
        return feed

    def shore_packets(self):
        """The packets of the diver's that shore's node received (its JSON lines)."""
        return [e for e in self.shore_events() if e.get("event") == "packet_received" and e.get("src") in (DIVER, "diver")]

    def flash(self, board, name, *extra):
        t = time.monotonic()
        r = subprocess.run(_acomm() + ["flash", "--board", name, "--port", board.usb, "--reset"] + list(extra),
                           stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=FLASH_TIMEOUT_S)
        secs = time.monotonic() - t
        if r.returncode:
            raise ScenarioError("acomm flash --board %s failed (%d): %s" % (name, r.returncode,
                                                                          (r.stdout + r.stderr).strip()[-400:]))
        return secs

    def _sky_tap(self, to, data):
        # the Iridium line; notes when the session with the diver's fragment
        # began (step 3) and when its result came back
        with self.lock:
            if (to == mt.DEVICE and self.session_at is None and b"AT+SBDIX" in data.upper() and self.sky.mo
                    and any(f[0] == DIVER for f in mt.relayed_fragments([self.sky.mo]))):
                self.session_at = time.monotonic()
            elif to == mt.HOST and self.session_at is not None and self.result_at is None and b"+SBDIX:" in data:
                self.result_at = time.monotonic()
            elif to == mt.DEVICE and self.reset_at and self.asked_from is None and b"AT+SBDIX" in data.upper():
                # the rebooted buoy's first session: what it sends from here on is its new life's
                self.asked_from = len(self.sky.order)
            self.sky.feed(to, data)

    def _settled(self):
        # every packet the buoy took is at shore, and its completion came back
        # after a segment the rebooted buoy sent (a completion that arrives
        # before it asks finds no transfer, and is not taken)
        with self.lock:
            if self.asked_from is None:
                return False
            order = self.sky.order[self.asked_from:]
            custody = set(self.sea.custody)
        done, asked = set(), False
        for kind, data in order:
            if kind == "mo" and mt.frame_segment(data)[1] is not None:
                asked = True
            elif kind == "mt" and asked:
                done.update(mt.completions([data]))
        return custody <= done and len(self.shore_packets()) >= len(custody)

    # -- the run ----------------------------------------------------------------------------
    def run(self):
        say = self.say
        fw = firmware("rp2040-stock")
        diver_board(self.path("boards"), self.period_s)
        self.start(["emulate", "seatrac", "--link", self.path("sea-buoy"),
                    "--peer", "%d:%s" % (DIVER, self.path("sea-diver")), "--log", self.path("seatrac.log")], "seatrac", 2)
        # sessions of 2 s instead of the default 8 (a real one takes 10-60 s)
        self.start(["emulate", "iridium", "--link", self.path("sky-buoy"),
                    "--peer", "%d:%s" % (SHORE, self.path("sky-shore")), "--option", "session_ms=2000",
                    "--log", self.path("iridium.log")], "iridium", 2)
        # shore's adverts once an hour, as the buoy's: each one costs a message
        self.start(["node", "--name", "shore", "--id", str(SHORE), "--known", "buoy=%d" % BUOY,
                    "--known", "diver=%d" % DIVER, "--modem", "iridium:" + self.path("sky-shore"),
                    "--advert-period", "3600", "--json", "--inbox", self.path("inbox")], "shore", 0)
        buoy = self.buoy = PicoBoard(fw, flash=self.path("buoy-flash.img"))
        self.closers.append(buoy.stop)
        # the diver on the image with all of acomm frozen, when built: its flash is then
        # main.py and config.py (acomm flash finds the frozen modules), a few seconds
        diver = self.diver = PicoBoard(firmware("rp2040-full") or fw, flash=self.path("diver-flash.img"))
        self.closers.append(diver.stop)
        sky = mt.Bridge(buoy.uart1, self.path("sky-buoy"), self._sky_tap)
        for b in (mt.Bridge(buoy.uart0, self.path("sea-buoy"), self.tap(self.sea)),
                  mt.Bridge(diver.uart1, self.path("sea-diver")), sky):
            self.closers.insert(0, b.close)
        if mt.wait_for(lambda: any(e.get("event") == "ready" for e in self.shore_events()), 30) is None:
            raise ScenarioError("shore's node did not start: %s" % open(self.path("shore.out")).read()[-400:])

        # 1. both boards flashed as a user flashes a Pico
        r = {"flash_seconds": self.flash(buoy, "buoy_pico")}
        say("buoy flashed in %.1f s" % r["flash_seconds"])
        buoy_con = self.console("buoy", buoy)
        first_boot = buoy_con.wait_ready(1) - buoy.stats()["last_reset_ms"]
        r["diver_flash_seconds"] = self.flash(diver, "diver_pico", "--boards", self.path("boards"))
        diver_con = self.console("diver", diver)
        diver_con.wait_ready(1)
        say("both boards running; the diver reports every %d s" % self.period_s)

        # 2. the diver's first report in the buoy's store; the diver goes off
        if mt.wait_for(lambda: list(self.sea.custody), 3 * self.period_s + 60) is None:
            raise ScenarioError("the buoy took no packet from the diver; buoy console %r, diver console %r"
                                % (buoy_con.lines[-5:], diver_con.lines[-5:]))
        r["diver_stats"] = diver.stats()
        self.cons.remove(diver_con)
        diver_con.close()
        self.closers.remove(diver.stop)
        diver.stop()
        say("the buoy holds the diver's packet %s; the diver is off" % sorted(set(self.sea.custody)))

        # 3. a reset in the session that carries it
        if mt.wait_for(lambda: self.session_at, 150) is None:
            raise ScenarioError("the buoy never started an Iridium session with the diver's packet; "
                                "sessions %r, console %r" % (self.sky.sessions, buoy_con.lines[-5:]))
        time.sleep(0.3)  # the command is at the modem: the session (2 s) is under way
        n = len(buoy_con.ready_ms)
        buoy.reset()
        self.reset_at = time.monotonic()
        at = buoy.stats()["last_reset_ms"]
        say("the buoy was reset during the Iridium session that carries the diver's packet")
        r["boot_to_ready_ms"] = buoy_con.wait_ready(n + 1) - at
        r["first_boot_ms"] = first_boot

        # 4. out of its store, never sent again
        r["drained"] = mt.wait_for(self._settled, 180) is not None
        # a late duplicate would show here; the buoy is idle meanwhile (the
        # diver off, its packet gone): the share of that time its core ran,
        # not in WFI/WFE (the runner's sleep_ms)
        s0 = buoy.stats()
        time.sleep(5)
        s1 = buoy.stats()
        r["idle_cpu_percent"] = 100.0 * (1 - (s1["sleep_ms"] - s0["sleep_ms"]) / (s1["sim_ms"] - s0["sim_ms"]))
        # the reset fell between the session's command and its result
        r["reset_in_session"] = self.session_at < self.reset_at < (self.result_at or 0)
        r["buoy_stats"] = s1
        say("done" if r["drained"] else "the buoy did not finish the packet")
        # the store as a user reads it: Ctrl-C stops main.py (the watchdog then
        # resets the board 8 s later, long after the copy)
        for c in self.cons:
            c.close()
        self.cons = []
        store_copy = self.path("acomm.store")
        from ..board.flash import mpremote_command

        cp = subprocess.run(mpremote_command() + ["connect", buoy.usb, "fs", "cp", ":/data/acomm.store", store_copy],
                            stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60)
        r["store"] = store_records(store_copy) if cp.returncode == 0 else None
        r["store_error"] = None if cp.returncode == 0 else (cp.stdout + cp.stderr).strip()[-300:]
        self.stop_procs()
        # the figures from the modems' captures (the taps above only paced the run)
        logs = []
        for name, reader in (("seatrac", mt.SeatracLine(BUOY)), ("iridium", mt.IridiumLine())):
            with open(self.path(name + ".log")) as f:
                logs.append(mt.feed_capture(reader, read_capture(f)[1]))
        sea_log, sky_log = logs
        r.update(self._figures(sea_log, sky_log))
        r.update({"resets": r["buoy_stats"]["ctl_resets"], "buoy_console": buoy_con.lines,
                  "diver_console": diver_con.lines, "sessions": sky_log.sessions,
                  "mo_segments": [m.hex() for m in sky_log.mo_sent if mt.frame_segment(m)[1] is not None]})
        return r

    def console(self, name, board):
        c = mt.Console(board, READY[name], BOOT_TIMEOUT_S)
        self.cons.append(c)
        return c

    def stop_procs(self):
        # SIGTERM first: the emulators write their captures out on the way
        for p, _ in self.procs:
            if p.poll() is None:
                p.terminate()
        for p, out in self.procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            out.close()
        self.procs = []

    def shore_events(self):
        try:
            with open(self.path("shore.out")) as f:
                return [json.loads(ln) for ln in f if ln.startswith("{") and ln.endswith("\n")]
        except (OSError, ValueError):
            return []

    def _figures(self, sea_log, sky_log):
        # from the buoy's acoustic line (custody) and its Iridium line (what
        # left): per diver packet, how many MO messages carried its fragments
        custody = sorted(set(sea_log.custody))
        copies = {}
        for origin, _final, pid, index in mt.relayed_fragments(sky_log.mo_sent):
            if origin == DIVER:
                copies[(pid, index)] = copies.get((pid, index), 0) + 1
        sent = sorted(set(pid for pid, _ in copies))
        at_shore = self.shore_packets()
        return {
            "custody": custody,
            "relayed": len([p for p in custody if p in sent]),
            "lost": len([p for p in custody if p not in sent]),
            "duplicates": sum(n - 1 for n in copies.values()),
            "mo_copies": dict(("%d/%d" % k, n) for k, n in copies.items()),
            "shore_packets": at_shore,
            "inbox": self._inbox(),
            "completions_read": mt.completions(sky_log.mt_read),
        }

    def _inbox(self):
        # [(file name, its bytes in hex)]: what shore's node saved of each packet
        d = self.path("inbox")
        out = []
        for name in sorted(os.listdir(d)) if os.path.isdir(d) else ():
            with open(os.path.join(d, name), "rb") as f:
                out.append((name, f.read().hex()))
        return out

    def close(self):
        for c in self.cons + self.closers:
            try:
                c() if callable(c) else c.close()
            except Exception:  # noqa: BLE001 - tear down what is left
                pass
        self.cons = self.closers = []
        self.stop_procs()


def store_records(path):
    """The records of a store file (acomm.transport.store's format, docs/wire-format.md), in file
    order: (kind "P" put or "D" delete, origin, pid, chunk) for a packet's, (kind, "meta", key)
    for the transport's own; None when the file is not a store."""
    import zlib

    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"ACS\x01":
        return None
    out = []
    p = 4
    while p + 12 <= len(data):
        if data[p] != 0xA5:
            p += 1
            continue
        kind = chr(data[p + 1])
        key = int.from_bytes(data[p + 2:p + 6], "little")
        n = int.from_bytes(data[p + 6:p + 8], "little")
        end = p + 8 + n
        if end + 4 > len(data) or zlib.crc32(data[p:end]) != int.from_bytes(data[end:end + 4], "little"):
            p += 1
            continue
        if (key >> 16) & 0xFF == 0xFF:  # origin 255 is no node's: the packet ids' limit, the packets done
            out.append((kind, "meta", key))
        else:
            out.append((kind, (key >> 16) & 0xFF, key & 0xFFFF, key >> 24))
        p = end + 4
    return out


def run(period_s=5, say=None):
    """Runs the scenario once; its dict. A RuntimeError (ScenarioError) says what went wrong."""
    m = missing()
    if m:
        raise ScenarioError(m)
    r = Run(period_s, say)
    try:
        return r.run()
    except PicoError as e:  # a runner that did not start, a control port gone
        raise ScenarioError(str(e))
    finally:
        r.close()
        shutil.rmtree(r.dir, ignore_errors=True)
