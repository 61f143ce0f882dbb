# Node-discovery adverts as Micro-Modem mini-packets (seed 000: "This active
# advertisement takes the form of a mini-packet destined to the broadcast
# address"). A mini-packet carries 13 bits and takes about 0.7 s of air; a
# full packet at rate 0 takes about 4.7 s.
#
# The Link hands the driver an elided acomm ADVERT frame (acomm.frame,
# acomm.link.discovery): 3 bytes
#     0 TTT SSSS   type ADVERT (2), no flags byte, 4-bit sequence
#     node id
#     advert period in units of 4 s (1..255)
# When the node id equals the modem's own address (the Link's default
# identity address map), the node id is implied by the mini-packet's source
# address, and the rest fits in 13 bits:
#
#     bit 12      1: "this is an acomm advert" (the marker)
#     bits 11..8  the frame's sequence
#     bits 7..0   the period in 4 s units
#
# The receiver rebuilds the identical 3-byte frame with node id = the
# mini-packet's source address. Values with bit 12 clear, or a zero period,
# are not ours (someone else's use of mini-packets): counted and ignored.

from ..compat import const

MARKER = const(0x1000)
MASK = const(0x1FFF)
_ADVERT_BYTE = const(0x20)  # ADVERT (2) << 4, no flags byte


def advert_to_mini(frame, own_addr):
    # The 13-bit value for this frame, or None when it must go as a normal
    # packet (not a plain advert, or not for our own address).
    if own_addr is None or len(frame) != 3:
        return None
    b0 = frame[0]
    if b0 & 0xF0 != _ADVERT_BYTE or frame[1] != own_addr or frame[2] == 0:
        return None
    return MARKER | ((b0 & 0x0F) << 8) | frame[2]


def mini_to_advert(value, src_addr):
    # The elided ADVERT frame a mini-packet from src_addr stands for, or None.
    value &= MASK
    if not value & MARKER or not value & 0xFF or not 0 <= src_addr <= 254:
        return None
    return bytes((_ADVERT_BYTE | ((value >> 8) & 0x0F), src_addr, value & 0xFF))
