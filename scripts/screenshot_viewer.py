"""Screenshots of a replay in the Rerun web viewer, in its light and dark themes.

    python scripts/screenshot_viewer.py run.rrd --out-dir shots/ [--themes light,dark]
        [--size 1920x1080] [--wait 180] [--chromium chromium]

What a person would see when opening the replay: the ``rerun`` program that rerun-sdk ships
serves the web viewer on 127.0.0.1 (free ports), which loads the .rrd over HTTP from a small
file server of this script's; headless Chromium (Debian:
``apt-get install chromium``) opens the page with the colour scheme the theme asks for
(the viewer follows the browser's), waits for the viewer to load and draw, and saves
``<stem>-<theme>.png``. The browser is driven over its DevTools pipe, so nothing but the
standard library and Chromium is needed. WebGL comes from SwiftShader (no GPU needed).
"""

from __future__ import annotations

import argparse
import base64
import fcntl
import functools
import http.server
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any
from urllib.parse import quote

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from replay.sinks.rerun.live import ViewerServer

THEMES = ("light", "dark")


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format: str, *args: Any) -> None:
        return None

    def end_headers(self) -> None:  # the web viewer is on another port
        self.send_header("Access-Control-Allow-Origin", "*")
        super().end_headers()


class DevTools:
    """The Chrome DevTools protocol over ``--remote-debugging-pipe`` (fds 3 and 4)."""

    def __init__(self, chromium: str, size: tuple[int, int], profile: Path) -> None:
        to_child_r, self._to_child = os.pipe()
        self._from_child, from_child_w = os.pipe()
        # high numbers first, so that moving them onto 3 and 4 in the child cannot collide
        r_hi, w_hi = fcntl.fcntl(to_child_r, fcntl.F_DUPFD, 10), fcntl.fcntl(
            from_child_w, fcntl.F_DUPFD, 10)
        os.close(to_child_r)
        os.close(from_child_w)

        def fds() -> None:  # in the child: its fd 3 reads our commands, fd 4 writes replies
            os.dup2(r_hi, 3)
            os.dup2(w_hi, 4)

        cmd = [chromium, "--headless=new", "--no-sandbox", "--remote-debugging-pipe",
               "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
               "--hide-scrollbars", "--no-first-run", f"--user-data-dir={profile}",
               f"--window-size={size[0]},{size[1]}", "about:blank"]
        self.proc = subprocess.Popen(cmd, preexec_fn=fds, pass_fds=(3, 4),
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(r_hi)
        os.close(w_hi)
        self._next = 0
        self._buf = b""

    def call(self, method: str, session: str | None = None, **params: Any) -> dict[str, Any]:
        self._next += 1
        msg: dict[str, Any] = {"id": self._next, "method": method, "params": params}
        if session:
            msg["sessionId"] = session
        os.write(self._to_child, json.dumps(msg).encode() + b"\0")
        while True:
            reply = self._read()
            if reply.get("id") == self._next:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return dict(reply.get("result", {}))

    def _read(self) -> dict[str, Any]:
        while b"\0" not in self._buf:
            chunk = os.read(self._from_child, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed its DevTools pipe")
            self._buf += chunk
        raw, self._buf = self._buf.split(b"\0", 1)
        return dict(json.loads(raw))

    def close(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


def screenshot(chromium: str, url: str, theme: str, size: tuple[int, int], wait_s: float,
               out: Path) -> None:
    with tempfile.TemporaryDirectory(prefix="dsp-chromium-") as profile:
        tools = DevTools(chromium, size, Path(profile))
        try:
            target = tools.call("Target.createTarget", url="about:blank")["targetId"]
            session = tools.call("Target.attachToTarget", targetId=target,
                                 flatten=True)["sessionId"]
            tools.call("Emulation.setDeviceMetricsOverride", session, width=size[0],
                       height=size[1], deviceScaleFactor=1, mobile=False)
            tools.call("Emulation.setEmulatedMedia", session, features=[
                {"name": "prefers-color-scheme", "value": theme}])
            tools.call("Page.enable", session)
            tools.call("Page.navigate", session, url=url)
            out.write_bytes(_settled(tools, session, wait_s))
        finally:
            tools.close()


def _settled(tools: DevTools, session: str, wait_s: float, every_s: float = 3.0) -> bytes:
    """A screenshot once the page is loaded (``document.readyState`` complete) and has
    stopped changing (two shots ``every_s`` apart alike: the viewer has drawn the data it
    was sent), or the last one after ``wait_s``. A busy machine only makes it wait longer."""
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline:
        state = tools.call("Runtime.evaluate", session, expression="document.readyState")
        if state.get("result", {}).get("value") == "complete":
            break
        time.sleep(0.5)
    previous = b""
    while True:
        time.sleep(every_s)
        shot = base64.b64decode(tools.call("Page.captureScreenshot", session,
                                           format="png")["data"])
        if shot == previous or time.monotonic() > deadline:
            return shot
        previous = shot


def _shrink(path: Path, width: int) -> None:
    """Scale a PNG down to ``width`` pixels (Pillow, which matplotlib brings)."""
    from PIL import Image

    with Image.open(path) as im:
        if im.width > width:
            im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
            im.save(path, optimize=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("rrd", type=Path, help="a replay saved with dsp-replay --save")
    p.add_argument("--out-dir", type=Path, default=Path("."))
    p.add_argument("--themes", default="light,dark",
                   help="light, dark or light,dark (the default: both)")
    p.add_argument("--size", default="1920x1080", help="browser window, WIDTHxHEIGHT")
    p.add_argument("--wait", type=float, default=180.0,
                   help="at most this many seconds for the page to load and its drawing to settle "
                   "(default %(default)s; it returns as soon as two shots 3 s apart agree)")
    p.add_argument("--out-width", type=int, metavar="PX",
                   help="scale the saved screenshot to this width (e.g. 1440 for a README)")
    p.add_argument("--chromium", default=shutil.which("chromium") or "chromium")
    args = p.parse_args(argv)
    if not args.rrd.is_file():
        p.error(f"{args.rrd}: no such file")
    themes = [t.strip() for t in args.themes.split(",") if t.strip()]
    if not themes or set(themes) - set(THEMES):
        p.error(f"--themes {args.themes!r}: choose from {', '.join(THEMES)}")
    width, height = (int(v) for v in args.size.lower().split("x"))
    args.out_dir.mkdir(parents=True, exist_ok=True)
    # a plain kill ends the browser and the server too (the finally blocks run)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    # the viewer fetches the whole file over HTTP (faster than having it streamed to it)
    handler = functools.partial(_QuietHandler, directory=str(args.rrd.resolve().parent))
    files = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=files.serve_forever, daemon=True).start()
    rrd_url = f"http://127.0.0.1:{files.server_address[1]}/{quote(args.rrd.name)}"
    try:
        with ViewerServer(web_port=0, grpc_port=0) as server:
            url = f"http://127.0.0.1:{server.web_port}/?url={quote(rrd_url, safe='')}"
            for theme in themes:
                out = args.out_dir / f"{args.rrd.stem}-{theme}.png"
                screenshot(args.chromium, url, theme, (width, height), args.wait, out)
                if args.out_width:
                    _shrink(out, args.out_width)
                print(f"wrote {out}")
    finally:
        files.shutdown()
        files.server_close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
