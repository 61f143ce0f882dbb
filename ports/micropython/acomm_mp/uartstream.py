# machine.UART as the byte stream acomm.node.Node reads and writes.
#
# machine.UART.read() returns None when nothing is waiting (pyserial gives
# b""), write() may take part of the bytes or return None on a timeout, and
# a read that allocates a new buffer each time churns a small heap. So the
# stream reads with readinto() into one preallocated buffer, only when the
# UART says bytes are waiting, and hands the node a bytes copy of what came
# (the link may keep it). Node.step() keeps what a short write left.


class UartStream:
    def __init__(self, uart, bufsize=256):
        self.uart = uart
        self._buf = bytearray(bufsize)
        self._mv = memoryview(self._buf)
        self.bytes_in = 0
        self.bytes_out = 0

    def read(self, n=256):
        if not self.uart.any():
            return None
        if n > len(self._buf):
            n = len(self._buf)
        k = self.uart.readinto(self._mv[:n])
        if not k:
            return None
        self.bytes_in += k
        return bytes(self._mv[:k])

    def write(self, data):
        n = self.uart.write(data)
        if not n:
            return 0
        self.bytes_out += n
        return n
