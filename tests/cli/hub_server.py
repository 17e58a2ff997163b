#!/usr/bin/env python3
"""tests/cli/hub_server.py - a stand-in for the Hugging Face hub on 127.0.0.1, for tests/cli/test_download.sh.

    python3 hub_server.py ROOT PORT_FILE LOG_FILE CONTROL_FILE

Serves the files under ROOT at their paths (the test builds ROOT/<repo>/resolve/<revision>/<path>):
GET (with `Range: bytes=N-`: 206 and Content-Range; N past the end: 416) and HEAD (the full size); for
.pth and .safetensors files both carry `X-Linked-Etag: "<sha256 of the file>"`, as the hub does for LFS
files. Binds
an unused port on 127.0.0.1 and writes it to PORT_FILE. Appends one line per request to LOG_FILE:
"METHOD PATH range=<Range header or -> auth=<none|ok|bad>". CONTROL_FILE (JSON, read at every request, so
the test changes the faults between runs without a restart) may hold:
    "token":     a bearer token every request must carry (else 401)
    "missing":   paths answered 404 (with X-Error-Code: EntryNotFound, as the hub does)
    "truncate":  paths whose GET sends half the file as a complete response (HEAD still says the full size)
    "drop_once": paths whose first GET announces the full size, sends half and drops the connection
    "bad_etag":  paths whose X-Linked-Etag is not the digest of the bytes sent (the sha256 of b"other")
    "no_etag":   paths announced without X-Linked-Etag
    "flip":      paths whose GET sends the right size with one byte changed (the middle one)
"""
import hashlib
import json
import os
import socket
import sys
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

ROOT, PORT_FILE, LOG_FILE, CONTROL_FILE = sys.argv[1:5]
DROPPED = set()
LOCK = threading.Lock()
DIGESTS = {}


def sha256_of(full):
    key = (full, os.path.getmtime(full), os.path.getsize(full))
    with LOCK:
        if key in DIGESTS:
            return DIGESTS[key]
    h = hashlib.sha256()
    with open(full, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    with LOCK:
        DIGESTS[key] = h.hexdigest()
    return DIGESTS[key]


def control():
    try:
        with open(CONTROL_FILE) as f:
            return json.load(f)
    except (OSError, ValueError):
        return {}


def listed(c, key, path):
    return any(path.endswith("/" + m) for m in c.get(key, []))


class Hub(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.0"

    def log_message(self, fmt, *args):  # quiet: the log file is the record
        pass

    def answer(self, head_only):
        c = control()
        path = self.path.split("?", 1)[0]
        auth = self.headers.get("Authorization")
        token = c.get("token")
        state = "none" if auth is None else ("ok" if token and auth == "Bearer " + token else "bad")
        with LOCK:
            with open(LOG_FILE, "a") as log:
                log.write("%s %s range=%s auth=%s\n" % (self.command, path, self.headers.get("Range", "-"), state))
        if token and state != "ok":
            return self.status(401, "Unauthorized", {"X-Error-Code": "GatedRepo"})
        rel = path.lstrip("/")
        full = os.path.normpath(os.path.join(ROOT, rel))
        if any(path.endswith("/" + m) for m in c.get("missing", [])) or not full.startswith(ROOT) or not os.path.isfile(full):
            return self.status(404, "Not Found", {"X-Error-Code": "EntryNotFound"})
        size = os.path.getsize(full)
        etag = None
        if full.endswith((".pth", ".safetensors")) and not listed(c, "no_etag", path):
            etag = hashlib.sha256(b"other").hexdigest() if listed(c, "bad_etag", path) else sha256_of(full)
        if head_only:
            self.send_response(200)
            self.send_header("Content-Length", str(size))
            self.send_header("Accept-Ranges", "bytes")
            if etag:
                self.send_header("X-Linked-Etag", '"%s"' % etag)
            self.end_headers()
            return
        start = 0
        rng = self.headers.get("Range")
        if rng and rng.startswith("bytes=") and rng.endswith("-"):
            start = int(rng[6:-1])
            if start >= size:
                return self.status(416, "Range Not Satisfiable", {"Content-Range": "bytes */%d" % size})
        with open(full, "rb") as f:
            f.seek(start)
            body = f.read()
        truncate = any(path.endswith("/" + m) for m in c.get("truncate", []))
        drop = False
        with LOCK:
            if any(path.endswith("/" + m) for m in c.get("drop_once", [])) and path not in DROPPED:
                DROPPED.add(path)
                drop = True
        if truncate:
            body = body[: len(body) // 2]
        mid = size // 2 - start
        if listed(c, "flip", path) and 0 <= mid < len(body):
            body = body[:mid] + bytes([body[mid] ^ 0x5A]) + body[mid + 1:]
        self.send_response(206 if start else 200)
        self.send_header("Content-Length", str(size - start if drop else len(body)))
        self.send_header("Accept-Ranges", "bytes")
        if start:
            self.send_header("Content-Range", "bytes %d-%d/%d" % (start, size - 1, size))
        if etag:
            self.send_header("X-Linked-Etag", '"%s"' % etag)
        self.end_headers()
        if drop:
            self.wfile.write(body[: len(body) // 2])
            self.wfile.flush()
            self.close_connection = True
            try:
                self.connection.shutdown(socket.SHUT_RDWR)
            except OSError:
                pass
            return
        self.wfile.write(body)

    def status(self, code, text, headers):
        self.send_response(code, text)
        for k, v in headers.items():
            self.send_header(k, v)
        self.send_header("Content-Length", "0")
        self.end_headers()

    def do_GET(self):
        try:
            self.answer(False)
        except (BrokenPipeError, ConnectionResetError):
            pass

    def do_HEAD(self):
        self.answer(True)


ROOT = os.path.realpath(ROOT)
server = ThreadingHTTPServer(("127.0.0.1", 0), Hub)
with open(PORT_FILE + ".tmp", "w") as f:
    f.write(str(server.server_address[1]))
os.rename(PORT_FILE + ".tmp", PORT_FILE)
server.serve_forever()
