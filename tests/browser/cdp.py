#!/usr/bin/env python3
"""Drives headless Chromium through the DevTools protocol on a pipe (--remote-debugging-pipe): no extra
Python package, no debugging port another process could reach. Steps run in the order given:

  cdp.py URL [--wait EXPR] [--eval EXPR] [--sleep S] [--screenshot FILE] ...

  --wait EXPR        polls the JavaScript expression until it is truthy (fails after --timeout seconds)
  --eval EXPR        evaluates it (promises awaited) and prints its JSON value on one line
  --sleep S          waits S seconds (the page keeps running: live updates arrive meanwhile)
  --screenshot FILE  a PNG of the whole page (of its top --max-height pixels)

Network: by default every request that leaves the machine goes to a proxy that is not there
(127.0.0.1:9), so a page that needs a CDN or any remote file fails to load it; loopback and file:// work.
Exit 0 when every step ran; 1 with the reason on stderr otherwise; 77 when Chromium is not installed.
"""
import argparse
import base64
import fcntl
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time


class Step(argparse.Action):
    def __call__(self, parser, namespace, values, option_string=None):
        namespace.steps.append((self.dest, values))


class Browser:
    def __init__(self, width, height):
        exe = shutil.which("chromium") or shutil.which("chromium-browser")
        if not exe:
            print("SKIP: chromium is not installed (deploy/install-deps.sh installs it)", file=sys.stderr)
            sys.exit(77)
        self.profile = tempfile.mkdtemp(prefix="cpgmatch-chromium-")
        to_browser_r, self.to_browser = os.pipe()
        self.from_browser, from_browser_w = os.pipe()
        # Chromium reads commands on fd 3 and writes on fd 4. Both ends are first moved above 9, so that
        # putting one on 3 cannot overwrite the other; 3 and 4 are then kept open (pass_fds) into exec.
        def above_9(fd):
            moved = fcntl.fcntl(fd, fcntl.F_DUPFD, 10)
            os.close(fd)
            return moved
        to_browser_r, from_browser_w = above_9(to_browser_r), above_9(from_browser_w)
        def child_fds():
            os.dup2(to_browser_r, 3)
            os.dup2(from_browser_w, 4)
        self.proc = subprocess.Popen(
            [exe, "--headless", "--no-sandbox", "--disable-gpu", "--remote-debugging-pipe",
             "--no-first-run", "--no-default-browser-check", "--disable-extensions",
             "--proxy-server=127.0.0.1:9", f"--user-data-dir={self.profile}",
             f"--window-size={width},{height}", "about:blank"],
            pass_fds=(3, 4), preexec_fn=child_fds,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser_r)
        os.close(from_browser_w)
        self.buffer = b""
        self.next_id = 0
        self.session = None

    def close(self):
        try:
            self.send("Browser.close")
        except Exception:
            pass
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        shutil.rmtree(self.profile, ignore_errors=True)

    def send(self, method, params=None, session=True, timeout=30.0):
        self.next_id += 1
        message = {"id": self.next_id, "method": method, "params": params or {}}
        if session and self.session:
            message["sessionId"] = self.session
        os.write(self.to_browser, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            while b"\0" in self.buffer:
                raw, self.buffer = self.buffer.split(b"\0", 1)
                reply = json.loads(raw)
                if reply.get("id") == self.next_id:
                    if "error" in reply:
                        raise RuntimeError(f"{method}: {reply['error']}")
                    return reply.get("result", {})
            if time.monotonic() > deadline:
                raise RuntimeError(f"{method}: no answer from chromium within {timeout:.0f} s")
            chunk = os.read(self.from_browser, 1 << 20)
            if not chunk:
                raise RuntimeError("chromium closed its pipe")
            self.buffer += chunk

    def open(self, url):
        target = self.send("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        self.send("Page.enable")
        self.send("Page.navigate", {"url": url})

    def evaluate(self, expression):
        result = self.send("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                                "returnByValue": True})
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails'].get('exception', {}).get('description')}")
        return result["result"].get("value")

    def screenshot(self, path, max_height=None):
        metrics = self.send("Page.getLayoutMetrics")
        size = metrics.get("cssContentSize") or metrics["contentSize"]
        height = min(size["height"], max_height) if max_height else size["height"]
        shot = self.send("Page.captureScreenshot", {
            "format": "png", "captureBeyondViewport": True,
            "clip": {"x": 0, "y": 0, "width": size["width"], "height": height, "scale": 1}})
        with open(path, "wb") as f:
            f.write(base64.b64decode(shot["data"]))


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("url")
    parser.set_defaults(steps=[])
    for name in ("wait", "eval", "sleep", "screenshot"):
        parser.add_argument(f"--{name}", dest=name, action=Step)
    parser.add_argument("--timeout", type=float, default=15.0, help="seconds a --wait may take")
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=900)
    parser.add_argument("--max-height", type=int, help="screenshots: at most this many pixels from the top")
    args = parser.parse_args()

    browser = Browser(args.width, args.height)
    try:
        browser.open(args.url)
        for kind, value in args.steps:
            if kind == "wait":
                deadline = time.monotonic() + args.timeout
                while not browser.evaluate(value):
                    if time.monotonic() > deadline:
                        raise RuntimeError(f"--wait {value}: still false after {args.timeout:g} s")
                    time.sleep(0.2)
            elif kind == "eval":
                print(json.dumps(browser.evaluate(value)), flush=True)
            elif kind == "sleep":
                time.sleep(float(value))
            elif kind == "screenshot":
                browser.screenshot(value, args.max_height)
    except RuntimeError as e:
        print(f"cdp.py: {e}", file=sys.stderr)
        return 1
    finally:
        browser.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
