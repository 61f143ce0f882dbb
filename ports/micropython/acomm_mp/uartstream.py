# machine.UART as the byte stream acomm.node.Node reads and writes.
#
# machine.UART.read() returns None when nothing is waiting (pyserial gives
# b""), and write() may take part of the bytes or return None on a timeout.
# The stream asks any() first, so a read never waits, then reads at most n
# bytes (the UART is opened with timeout=0: what is there, up to n). The
# bytes object read() returns is what the node keeps; no buffer of the
# stream's own sits beside it (a copy out of one costs the same
# allocation, and 256 bytes per UART for ever). Node.step() keeps what a
# short write left.


class UartStream:
    def __init__(self, uart):
        self.uart = uart
        self.bytes_in = 0
        self.bytes_out = 0

    def any(self):
        """Whether bytes wait (the UART's count); the loop's cheap question before it steps an idle node."""
        return self.uart.any()

    def read(self, n=256):
        """Up to n bytes that are waiting, or None when none are: never blocks."""
        if not self.uart.any():
            return None
        data = self.uart.read(n)
        if not data:
            return None
        self.bytes_in += len(data)
        return data

    def write(self, data):
        """How many bytes the UART took: 0 on a timeout."""
        n = self.uart.write(data)
        if not n:
            return 0
        self.bytes_out += n
        return n
