"""meshgauge-server for the Python tests, started one way: on port 0 with
--port_file (the bound port is read back, so no port is guessed), its
stderr kept for failure messages, restartable on the same port."""

import os
import signal
import socket
import subprocess
import tempfile
import time

SERVER = os.environ.get("MESHGAUGE_SERVER", "meshgauge-server")


def free_port():
    """A free loopback port, for the metrics endpoint only (the server
    reports the gRPC port it bound, not the metrics one)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class ServerProcess:
    """A meshgauge-server process; `flags` come after the defaults (no
    metrics endpoint unless `metrics`, no drain notice) and override them."""

    def __init__(self, *flags, metrics=False):
        self.tmp = tempfile.mkdtemp()
        self.flags = flags
        self.metrics_port = free_port() if metrics else None
        self.port = 0
        self.log = open(os.path.join(self.tmp, "server.log"), "w+")
        self._final = ""
        self.start()

    def start(self):
        """Starts the server (again on its first port after a stop)."""
        port_file = os.path.join(self.tmp, "port")
        if os.path.exists(port_file):
            os.remove(port_file)
        if self.log.closed:
            self.log = open(os.path.join(self.tmp, "server.log"), "a+")
        metrics = (f"127.0.0.1:{self.metrics_port}"
                   if self.metrics_port else "")
        self.proc = subprocess.Popen(
            [SERVER, f"--address=127.0.0.1:{self.port}",
             f"--metrics_address={metrics}", f"--port_file={port_file}",
             "--drain_notice_seconds=0", *self.flags],
            stderr=self.log)
        deadline = time.time() + 20
        while not _read(port_file):
            if time.time() > deadline or self.proc.poll() is not None:
                self.proc.kill()
                self.proc.wait(timeout=20)
                raise RuntimeError("server did not start: " + self.stderr())
            time.sleep(0.05)
        self.port = int(_read(port_file))
        self.target = f"127.0.0.1:{self.port}"

    def kill(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(timeout=20)

    def stop(self):
        """SIGTERM and wait; stderr() still returns the log."""
        if self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(timeout=20)
        if not self.log.closed:
            self._final = self.stderr()
            self.log.close()

    close = stop

    def stderr(self):
        if self.log.closed:
            return self._final
        self.log.flush()
        self.log.seek(0)
        return self.log.read()


def _read(path):
    if not os.path.exists(path):
        return ""
    with open(path) as f:
        return f.read().strip()
