#!/usr/bin/python3
"""A webhook receiver for Alertmanager, for the stack test and for trying the
receiver out: appends each notification (Alertmanager's webhook JSON) as one
line to FILE.

Usage: webhook_catcher.py PORT FILE [ADDRESS]   (ADDRESS default 0.0.0.0:
the stack's Alertmanager reaches it as host.docker.internal, the Docker
bridge's address on this host)
"""
import http.server
import json
import sys


class Handler(http.server.BaseHTTPRequestHandler):
    def do_POST(self):
        body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
        try:
            line = json.dumps(json.loads(body))
        except ValueError:
            line = json.dumps({"unparsed": body.decode("utf-8", "replace")})
        with open(sys.argv[2], "a") as f:
            f.write(line + "\n")
        self.send_response(200)
        self.end_headers()

    def log_message(self, *args):
        pass


if __name__ == "__main__":
    address = sys.argv[3] if len(sys.argv) > 3 else "0.0.0.0"
    http.server.ThreadingHTTPServer(
        (address, int(sys.argv[1])), Handler).serve_forever()
