# `acomm bench board`: the buoy on its own chip (acomm_cpython.bench.picobuoy):
# boards/buoy_pico flashed with `acomm flash --reset` onto an emulated
# Raspberry Pi Pico running MicroPython's own firmware, relaying a diver's
# report (the diver's tablet program on a second emulated Pico) from an
# emulated SeaTrac to an emulated Iridium modem, power-cycled during the
# Iridium session that carries it. Minutes of wall time: not in `all`.
#
#   rp2040_buoy_relayed_packets    diver's packets the buoy took custody of
#                                  that left over Iridium (MO sessions that
#                                  succeeded, from the modem's capture)
#   rp2040_buoy_lost_packets       taken in custody, never sent on
#   rp2040_buoy_duplicate_packets  extra MO messages carrying a fragment
#                                  already delivered to the gateway
#   rp2040_buoy_resets             the buoy's power cycles during the run
#   rp2040_flash_seconds           wall seconds of `acomm flash --board
#                                  buoy_pico --reset` (.mpy for armv6m)
#   rp2040_boot_to_ready_ms        simulated ms from the power cycle to the
#                                  buoy's ready line (imports, node built)
#   rp2040_first_boot_to_ready_ms  the same for the boot after the flash
#                                  (a machine.reset(), from mpremote)
#   rp2040_buoy_heap_free_bytes    what the buoy's ready line says is left of
#                                  the Pico's heap after a collection, at
#                                  its first boot (store empty): the buoy as
#                                  `acomm flash` installs it, nothing else
#   rp2040_buoy_heap_free_after_reset_bytes   the same after the power
#                                  cycle, its store holding the diver's packet
#   rp2040_buoy_idle_cpu_percent   the buoy's CPU duty while idle (5 s once
#                                  its packet is gone): simulated time its core
#                                  ran rather than slept in WFI/WFE, in %
#
# ACOMM_BOARD_RUN=FILE also writes the whole run (what shore received, the
# buoy's store records, the Iridium sessions, the consoles) to FILE as JSON,
# for the tests. Progress goes to stderr. Without the RP2040 runner or the
# firmware this fails with one line saying what is missing.
import json
import os
import sys

PER_RUNTIME = ()


def run(emit, quick=False):
    from acomm_cpython.bench import picobuoy

    if quick:
        # the run's boards as `acomm flash` stages them for the Pico
        # (compiled for armv6m), no emulator booted: minutes less
        for name, files, size in picobuoy.flash_plans():
            emit("rp2040_%s_flash_files" % name, files, "files")
            emit("rp2040_%s_flash_bytes" % name, size, "bytes")
        return
    m = picobuoy.missing()
    if m:
        raise RuntimeError(m)

    def say(s):
        print("board: " + s, file=sys.stderr, flush=True)

    r = picobuoy.run(say=say)  # its RuntimeError: `acomm bench` prints it on one line, exit 1
    out = os.environ.get("ACOMM_BOARD_RUN")
    if out:
        with open(out, "w") as f:
            json.dump(r, f, default=repr)
    emit("rp2040_buoy_relayed_packets", r["relayed"], "packets")
    emit("rp2040_buoy_lost_packets", r["lost"], "packets")
    emit("rp2040_buoy_duplicate_packets", r["duplicates"], "packets")
    emit("rp2040_buoy_resets", r["resets"], "resets")
    emit("rp2040_flash_seconds", round(r["flash_seconds"], 2), "s")
    emit("rp2040_boot_to_ready_ms", round(r["boot_to_ready_ms"], 1), "ms")
    emit("rp2040_first_boot_to_ready_ms", round(r["first_boot_ms"], 1), "ms")
    from acomm_cpython.board.picoflash import heap_free

    free = heap_free(r["buoy_console"])
    if len(free) < 2:
        raise RuntimeError("the buoy's ready lines give no free heap: %r" % r["buoy_console"][-6:])
    emit("rp2040_buoy_heap_free_bytes", free[0], "bytes")
    emit("rp2040_buoy_heap_free_after_reset_bytes", free[1], "bytes")
    emit("rp2040_buoy_idle_cpu_percent", round(r["idle_cpu_percent"], 1), "%")
