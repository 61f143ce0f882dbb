# A background thread for the one blocking exchange a port cannot do inside
# the node's loop (a TCP connection to a gateway, an HTTP request): jobs go
# in with submit(), their results come back through results(), and a
# socket pair wakes the loop (fileno()) when one is ready. Bounded: at most
# `capacity` jobs wait; submit() says False beyond that.

import queue
import socket
import threading


class Worker:
    """Runs fn(*args) for each job, one at a time, on its own thread."""

    def __init__(self, fn, capacity=64, name="acomm-shore"):
        self.fn = fn
        self._jobs = queue.Queue(capacity)
        self._done = queue.Queue()
        self._rx, self._tx = socket.socketpair()
        self._rx.setblocking(False)
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def submit(self, tag, *args):
        """Queues a job; -> False when `capacity` jobs are waiting already."""
        try:
            self._jobs.put_nowait((tag, args))
            return True
        except queue.Full:
            return False

    def results(self):
        """[(tag, fn's return value or the exception it raised)] since the last call."""
        drain(self._rx)
        out = []
        while True:
            try:
                out.append(self._done.get_nowait())
            except queue.Empty:
                return out

    def fileno(self):
        return self._rx.fileno()

    def _run(self):
        while True:
            job = self._jobs.get()
            if job is None:
                return
            tag, args = job
            try:
                r = self.fn(*args)
            except Exception as e:  # the job's failure is its result
                r = e
            self._done.put((tag, r))
            try:
                self._tx.send(b"!")
            except OSError:
                pass

    def close(self):
        try:
            self._jobs.put_nowait(None)
        except queue.Full:
            pass
        self._thread.join(2)
        self._rx.close()
        self._tx.close()


def drain(sock):
    """Reads a non-blocking wake-up socket empty (its bytes only say "look")."""
    try:
        while sock.recv(4096):
            pass
    except OSError:  # BlockingIOError included: nothing more
        pass


def pump_mt(driver, worker, now, stats):
    """Moves a ShoreDriver's MT messages to a Worker and its word back to the driver.

    A job's result is None (queued at the gateway) or a string or exception saying why not."""
    for h, imei, data in driver.take_mt():
        if not worker.submit(h, imei, data):
            driver.sent(now, h, "too many MT messages waiting")
    for h, r in worker.results():
        err = None if r is None else str(r) or type(r).__name__
        stats["mt_refused" if err else "mt_queued"] += 1
        driver.sent(now, h, err)
