# Calendar dates as day counts from 2020-01-01 (UTC), for the drivers that
# read a date from the sky (acomm.drivers.gps: NMEA; acomm.drivers.sms_wire:
# +CCLK). Apart from acomm.wallclock, so that a board that only reads
# Iridium's frame count never loads it.


def days2020(y, m, d):
    """Days from 2020-01-01 to the date y-m-d (Gregorian; negative before)."""
    if m <= 2:
        y -= 1
        m += 12
    # days from 0000-03-01, the leap day at the end of each year
    n = 365 * y + y // 4 - y // 100 + y // 400 + (153 * (m - 3) + 2) // 5 + d
    return n - 737731  # the same count for 2020-01-01
