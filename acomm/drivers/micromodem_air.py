# The Micro-Modem's packet rates and an airtime model, shared by the driver
# (its capabilities and watchdogs) and the emulator (when its packets end).
#
# Rates 0-5 (ref/modem-protocols.md 3.3; goby3 PACKET_SIZE): the largest
# frame in bytes and the bit rate (from a WHOI header whose repository was not
# identified, so unconfirmed). acomm sends one frame per cycle.
#
# Airtime, an ESTIMATE (nothing was measured):
#   mini-packet (and each leg of a ping, and a frame's acknowledgement):
#       mini_ms, 700 ms by default (seed 000: "about 0.7 s")
#   rate 0 (FH-FSK): the cycle header travels as its own mini-packet first,
#       then the data packet: mini_ms + fsk_gap_ms + 8 bits x n / 80 bit/s;
#       with the defaults a 32-byte frame takes 0.7 + 4.0 s (seed 000: "about
#       4 s more" than a mini-packet)
#   rates 1-5 (PSK): header and data in one packet: psk_ms (preamble, probe
#       and header) + 8 bits x n / bit rate
# Every figure is multiplied by `scale` so tests on real time can run fast.

from ..errors import AcommError

FRAME_BYTES = (32, 64, 64, 256, 256, 256)
BITRATE = (80, 250, 500, 1200, 1300, 5300)
FRAMES_PER_PACKET = (1, 3, 3, 2, 2, 8)  # what the modem could carry; acomm uses 1


class Airtime:
    def __init__(self, mini_ms=700, fsk_gap_ms=800, psk_ms=1000, scale=1.0):
        self.mini_ms_ = mini_ms
        self.fsk_gap_ms = fsk_gap_ms
        self.psk_ms = psk_ms
        self.scale = scale

    def mini_ms(self):
        return int(self.mini_ms_ * self.scale)

    def packet_ms(self, rate, nbytes):
        bits_ms = nbytes * 8000 // BITRATE[rate]
        if rate == 0:
            t = self.mini_ms_ + self.fsk_gap_ms + bits_ms
        else:
            t = self.psk_ms + bits_ms
        return int(t * self.scale)

    def travel_ms(self, metres, sound_speed):
        # propagation is physics: never scaled
        return int(metres * 1000 / sound_speed)


def check_rate(rate):
    if not isinstance(rate, int) or not 0 <= rate <= 5:
        raise AcommError("Micro-Modem rate %r outside 0..5" % (rate,))
    return rate
