#!/usr/bin/env python3
"""The monitor in a real browser (issue 41): headless Chromium, driven over the DevTools
protocol, loads `photonfarm serve`'s page against a queue with jobs in every state, and the
rendered DOM is asserted on: the job list, a progress bar's value, the frame grid's
colours, the stage bars, the latest frame's pixel size, a hostile job name shown as text;
then a worker completes a frame and the page's progress moves without a reload.

  monitor_browser_test.py PHOTONFARM SCENE WORKDIR
Prints one line per check; exit 1 when one fails. Without chromium it says so and passes
(bootstrap.sh installs it for the tests)."""
import base64
import json
import os
import shutil
import socket
import sqlite3
import struct
import subprocess
import sys
import time
import urllib.request

photonfarm, scene, work = sys.argv[1], sys.argv[2], sys.argv[3]
failed = 0
HOSTILE = '<img src=x onerror="document.title=\'pwned\'">'


def check(what, condition):
    global failed
    print(("ok   " if condition else "FAIL ") + what, flush=True)
    failed += 0 if condition else 1


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# photonfarm's environment: under AddressSanitizer the build asks for libraries to preload
# into it (PF_CHILD_PRELOAD: lavapipe stays mapped, as in the other CLI tests, so its one
# global buffer is not reported as a leak), which this Python process must not get itself.
CHILD_ENV = dict(os.environ)
if os.environ.get("PF_CHILD_PRELOAD"):
    CHILD_ENV["LD_PRELOAD"] = os.environ["PF_CHILD_PRELOAD"]


def run(*args):
    return subprocess.run([photonfarm, *args], capture_output=True, text=True, timeout=300,
                          env=CHILD_ENV)


class DevTools:
    """Just enough of a WebSocket client (RFC 6455) for Chromium's DevTools protocol."""

    def __init__(self, url):
        host, port_path = url[len("ws://"):].split(":", 1)
        port, path = port_path.split("/", 1)
        self.sock = socket.create_connection((host, int(port)), timeout=30)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall(("GET /%s HTTP/1.1\r\nHost: %s:%s\r\nUpgrade: websocket\r\n"
                           "Connection: Upgrade\r\nSec-WebSocket-Key: %s\r\n"
                           "Sec-WebSocket-Version: 13\r\n\r\n" % (path, host, port, key)).encode())
        response = b""
        while b"\r\n\r\n" not in response:
            response += self.sock.recv(4096)
        self.buffer = response.split(b"\r\n\r\n", 1)[1]
        self.next_id = 0

    def _read(self, count):
        while len(self.buffer) < count:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise EOFError("DevTools closed the connection")
            self.buffer += chunk
        data, self.buffer = self.buffer[:count], self.buffer[count:]
        return data

    def _frame(self):
        first, second = self._read(2)
        length = second & 0x7F
        if length == 126:
            length = struct.unpack(">H", self._read(2))[0]
        elif length == 127:
            length = struct.unpack(">Q", self._read(8))[0]
        return first & 0x0F, self._read(length)

    def call(self, method, **params):
        self.next_id += 1
        payload = json.dumps({"id": self.next_id, "method": method, "params": params}).encode()
        mask = os.urandom(4)
        header = bytes([0x81])
        if len(payload) < 126:
            header += bytes([0x80 | len(payload)])
        else:
            header += bytes([0x80 | 126]) + struct.pack(">H", len(payload))
        self.sock.sendall(header + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))
        while True:
            opcode, data = self._frame()
            if opcode == 1:
                message = json.loads(data)
                if message.get("id") == self.next_id:
                    return message.get("result", {})

    def value(self, expression):
        result = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return result.get("result", {}).get("value")

    def wait(self, expression, seconds=20):
        deadline = time.time() + seconds
        while time.time() < deadline:
            value = self.value(expression)
            if value:
                return value
            time.sleep(0.2)
        return self.value(expression)


browser = shutil.which("chromium") or shutil.which("chromium-browser")
if not browser:
    print("no chromium: the browser test is skipped (bootstrap.sh deps installs it)")
    sys.exit(0)

shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
db = os.path.join(work, "farm.db")
out = os.path.join(work, "out")
os.makedirs(out)


def enqueue(name, frames, priority):
    result = run("enqueue", scene, "--frames", frames, "--size", "16x12", "--quality", "preview",
                 "--out", os.path.join(out, name + ".####.exr"), "--name", name,
                 "--priority", str(priority), "--db", db)
    check("enqueue %s" % name, result.returncode == 0)
    return int(result.stdout.strip() or 0)


# Jobs in every state: done (rendered here), running, failed, paused, canceled, queued.
done = enqueue(HOSTILE, "1-2", 100)
check("the done job renders", run("worker", "--once", "--max-frames", "2", "--db", db).returncode == 0)
running = enqueue("running", "1-3", 0)
failed_job = enqueue("failed", "1-2", 0)
paused = enqueue("paused", "1-2", 0)
canceled = enqueue("canceled", "1-2", 0)
live = enqueue("live", "1-2", 50)
run("pause", str(paused), "--db", db)
run("cancel", str(canceled), "--db", db)
with sqlite3.connect(db) as connection:  # states a test cannot wait for a worker to reach
    connection.execute("UPDATE tasks SET status = 'failed', attempt = 3 WHERE job_id = ?",
                       (failed_job,))
    connection.execute("UPDATE jobs SET status = 'failed' WHERE id = ?", (failed_job,))
    connection.execute("UPDATE tasks SET status = 'running' WHERE job_id = ? AND first_frame = 1",
                       (running,))
    connection.execute("UPDATE jobs SET status = 'running', started_at = 1 WHERE id = ?",
                       (running,))

server = subprocess.Popen([photonfarm, "serve", "--listen", "127.0.0.1:0", "--poll-ms", "200",
                           "--db", db], stdout=subprocess.PIPE, text=True, env=CHILD_ENV)
line = server.stdout.readline()
port = int(line.rsplit(":", 1)[1].strip("/\n")) if "listening" in line else 0
check("serve listens", port > 0)
debug_port = free_port()
chrome = subprocess.Popen([browser, "--headless=new", "--no-sandbox", "--disable-gpu",
                           "--disable-dev-shm-usage",  # containers' /dev/shm is small
                           "--remote-debugging-port=%d" % debug_port,
                           "--user-data-dir=" + os.path.join(work, "profile"),
                           "http://127.0.0.1:%d/?job=%d" % (port, done)],
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
try:
    target = None
    for _ in range(100):
        try:
            with urllib.request.urlopen("http://127.0.0.1:%d/json/list" % debug_port) as r:
                pages = [t for t in json.load(r) if t.get("type") == "page"]
            if pages:
                target = pages[0]
                break
        except OSError:
            pass
        time.sleep(0.2)
    check("chromium's DevTools answer", target is not None)
    page = DevTools(target["webSocketDebuggerUrl"])

    rows = page.wait("document.querySelectorAll('#jobs tbody tr').length === 6 && "
                     "document.querySelectorAll('#jobs tbody tr').length")
    check("the job list shows the 6 jobs (%s)" % rows, rows == 6)
    states = page.value("[...document.querySelectorAll('#jobs tbody tr td:nth-child(3)')]"
                        ".map(c => c.textContent).sort().join(',')")
    check("every state is shown (%s)" % states,
          states == "canceled,done,failed,paused,queued,running")
    value = page.value("document.querySelector('#jobs tr[data-job=\"%d\"] progress').value" % done)
    check("the done job's progress bar is full (%s of 2)" % value, value == 2)
    preset = page.value("document.querySelector('#jobs tr[data-job=\"%d\"] td:nth-child(9)')"
                        ".textContent" % done)
    check("the done job shows the preset chosen and why (%s)" % preset,
          preset == "previewas enqueued")
    name = page.value("document.querySelector('#jobs tr[data-job=\"%d\"] td:nth-child(2)')"
                      ".textContent" % done)
    check("a hostile job name is shown as its text", name == HOSTILE)
    check("and never became an element or ran",
          page.value("document.querySelectorAll('img[src=\"x\"]').length") == 0 and
          page.value("document.title") != "pwned")
    cells = page.wait("document.querySelectorAll('#frame-grid .cell.done').length === 2 && "
                      "[...document.querySelectorAll('#frame-grid .cell')].map(c => "
                      "getComputedStyle(c).backgroundColor).join('|')")
    check("the frame grid has 2 done frames, coloured green (%s)" % cells,
          bool(cells) and all(c == "rgb(68, 170, 68)" for c in cells.split("|")))
    bars = page.wait("document.querySelectorAll('#frame-bars .bar').length === 2 && "
                     "[...document.querySelectorAll('#frame-bars .bar')].map(b => "
                     "b.querySelectorAll('i[data-stage]').length)")
    check("each frame's stacked bar has its stages (%s)" % bars,
          bool(bars) and len(bars) == 2 and all(n >= 3 for n in bars))
    size = page.wait("document.getElementById('last-frame').naturalWidth > 0 && "
                     "document.getElementById('last-frame').naturalWidth + 'x' + "
                     "document.getElementById('last-frame').naturalHeight")
    check("the latest frame is shown at its size (%s)" % size, size == "16x12")

    decisions = page.wait("[...document.querySelectorAll('#decisions tbody tr')].map(r => "
                          "[...r.children].slice(0, 3).map(c => c.textContent).join(':'))"
                          ".join(' ')")
    check("the decisions table has bih_build built once (%s)" % decisions,
          bool(decisions) and "bih_build:built:1" in decisions.split(" "))
    per_frame = page.value("[...document.querySelectorAll('#per-frame tbody tr')].map(r => "
                           "r.children[1].textContent).join(',')")
    check("peaks and bytes are listed for both frames (%s)" % per_frame, per_frame == "2,2,2")

    # Charts: each stage that ran has its distribution (a box from median to p95 and a
    # median tick); the decisions have their share bars.
    charts = page.value("[...document.querySelectorAll('#stages .dist')].map(d => "
                        "d.dataset.stage + '=' + d.querySelectorAll('.box, .median, .whisker')"
                        ".length).join(',')")
    outliers = page.value("[...document.querySelectorAll('#stages tbody tr')].map(r => "
                          "r.children[0].textContent + '=' + r.querySelectorAll('.outlier')"
                          ".length + '/' + r.querySelectorAll('button.frame-link').length)"
                          ".join(',')")
    check("each stage that ran names its outlier frame (%s)" % outliers,
          bool(outliers) and "shade=1/1" in outliers.split(","))
    check("every stage that ran has its distribution chart (%s)" % charts,
          bool(charts) and "shade=3" in charts.split(",") and "bih_build=3" in charts.split(","))
    shares = page.value("document.querySelectorAll('#decisions .share').length")
    check("every decision has its share bar (%s)" % shares, bool(shares) and shares >= 2)
    reused = page.value("[...document.querySelectorAll('#frame-bars i.reused')].map(i => "
                        "i.dataset.stage).join(',')")
    print("     reused parts in the bars: %s" % (reused or "none"))

    # A frame's log: clicking its cell shows what each attempt logged on its worker; a
    # hostile line stored in the queue is shown as text.
    with sqlite3.connect(db) as connection:
        connection.execute("UPDATE attempt_logs SET log = log || ? WHERE task_id = "
                           "(SELECT id FROM tasks WHERE job_id = ? AND first_frame = 2)",
                           (HOSTILE + "\n", done))
    page.value("document.querySelectorAll('#frame-grid .cell')[0].click()")
    log = page.wait("document.getElementById('frame-title').textContent === 'Frame 1' && "
                    "document.querySelector('#frame-logs pre') && "
                    "document.querySelector('#frame-logs pre').textContent")
    check("frame 1's log is shown on a click (%s lines)" % (log.count("\n") if log else 0),
          bool(log) and "event=claimed" in log and "event=rendered job=%d frame=1" % done in log)
    page.value("document.querySelectorAll('#frame-grid .cell')[1].click()")
    log = page.wait("document.getElementById('frame-title').textContent === 'Frame 2' && "
                    "document.querySelector('#frame-logs pre') && "
                    "document.querySelector('#frame-logs pre').textContent")
    check("a hostile log line is shown as its text",
          bool(log) and HOSTILE in log and
          page.value("document.querySelectorAll('img[src=\"x\"]').length") == 0 and
          page.value("document.title") != "pwned")

    # Live: a worker renders one frame of the "live" job; the page follows, no reload.
    page.value("window.notReloaded = true")
    before = page.value("document.querySelector('#jobs tr[data-job=\"%d\"] progress').value" % live)
    check("the live job starts at 0 (%s)" % before, before == 0)
    worker = run("worker", "--once", "--max-frames", "1", "--db", db)
    check("a worker renders a frame of it", worker.returncode == 0)
    after = page.wait("document.querySelector('#jobs tr[data-job=\"%d\"] progress').value === 1"
                      % live, seconds=10)
    check("its progress moves to 1 without a reload",
          after is True and page.value("window.notReloaded") is True)
finally:
    chrome.terminate()
    server.terminate()
    chrome.wait(timeout=30)
    server.wait(timeout=30)
sys.exit(1 if failed else 0)
