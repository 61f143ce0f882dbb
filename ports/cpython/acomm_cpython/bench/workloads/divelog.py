# A representative text payload for the compression figures: 2 KiB of a
# diver computer's log, one line every 10 s ("t02.30 depth 8.4m air 197 hr 84
# temp 14.2C"), with the occasional event line. Values drift like a real dive
# (descent, bottom time, ascent with a safety stop) so that lines share their
# structure but not their digits, which is what makes logs compress only
# partly. Generated from acomm.prng with integer arithmetic (tenths of a
# metre and of a degree; no float formatting), so both runtimes build the
# same bytes.

from acomm.prng import Prng

SIZE = 2048


def divelog(size=SIZE, seed=2024):
    rng = Prng(seed)
    out = bytearray()
    t = 0  # seconds
    depth = 0  # dm
    air = 205
    hr = 72
    temp = 180  # 0.1 C
    while len(out) < size:
        minutes = t // 60
        if minutes < 3:
            target = 180
        elif minutes < 20:
            target = 170 + rng.below(30)
        elif minutes < 24:
            target = 50
        else:
            target = 0
        depth += (target - depth) // 4 + rng.below(7) - 3
        if depth < 0:
            depth = 0
        if rng.below(3) == 0:
            air -= 1
        hr += rng.below(5) - 2
        temp += (140 - temp) // 10 + rng.below(3) - 1
        line = "t%02d.%02d depth %d.%dm air %d hr %d temp %d.%dC\n" % (
            minutes,
            t % 60,
            depth // 10,
            depth % 10,
            air,
            hr,
            temp // 10,
            temp % 10,
        )
        out.extend(line.encode())
        if rng.below(9) == 0:
            ev = ("note: buddy ok", "alarm: ascent rate", "note: photo", "deco: stop 3m 3min")[rng.below(4)]
            out.extend(("t%02d.%02d %s\n" % (minutes, t % 60, ev)).encode())
        t += 10
    return bytes(out[:size])
