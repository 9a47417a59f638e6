"""Render a recording in Rerun's web viewer, in a headless browser, to a PNG: what a user sees.

``python -m lerobot_policy_recent.logs.web_view EPISODE.rrd OUT.png`` serves the recording with
``rerun --web-viewer`` on loopback, opens it in headless Chromium (software GL) and takes a
screenshot over the DevTools protocol once the viewer has had time to load. It needs a Chromium on the PATH (Debian's ``chromium``);
the slow test ``tests/test_web_view.py`` runs it, and docs/logging.md shows its picture.
"""

from __future__ import annotations

import argparse
import asyncio
import base64
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path
from urllib.parse import quote

from lerobot_policy_recent.logs.rerun_sink import rerun_executable

BROWSERS = ("chromium", "chromium-browser", "google-chrome")


def browser() -> str | None:
    """A headless-capable Chromium on the PATH, or None."""
    return next((found for name in BROWSERS if (found := shutil.which(name))), None)


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _wait_for(port: int, timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        with socket.socket() as probe:
            if probe.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise TimeoutError(f"the Rerun web viewer did not listen on 127.0.0.1:{port} within {timeout:.0f} s")


def screenshot(rrd: Path, out: Path, *, size: tuple[int, int] = (1600, 900), load_seconds: float = 30.0) -> Path:
    """Serve ``rrd`` in Rerun's web viewer on loopback and screenshot it with headless Chromium."""
    chrome = browser()
    if chrome is None:
        raise FileNotFoundError("no Chromium on the PATH (apt-get install chromium)")
    web, grpc = _free_port(), _free_port()
    server = subprocess.Popen(
        [rerun_executable(), "--web-viewer", "--bind", "127.0.0.1", "--web-viewer-port", str(web)]
        + ["--port", str(grpc), str(rrd)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env={**os.environ, "RUST_LOG": "error"},
        start_new_session=True,
    )
    try:
        _wait_for(web, 30)
        url = f"http://127.0.0.1:{web}?url=" + quote(f"rerun+http://127.0.0.1:{grpc}/proxy", safe="")
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_bytes(asyncio.run(_capture(chrome, url, size, load_seconds)))
    finally:
        _stop_group(server)
    if not out.is_file():
        raise RuntimeError(f"Chromium wrote no screenshot to {out}")
    return out


async def _capture(chrome: str, url: str, size: tuple[int, int], load_seconds: float) -> bytes:
    """Open ``url`` in headless Chromium, wait ``load_seconds`` of real time (the viewer compiles its
    WebAssembly and streams the recording), then take a screenshot over the DevTools protocol."""
    import aiohttp  # Ray's dependency: a DevTools client without another package

    port = _free_port()
    browser_proc = subprocess.Popen(
        [
            chrome,
            "--headless=new",
            "--no-sandbox",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--ignore-gpu-blocklist",
            f"--window-size={size[0]},{size[1]}",
            f"--remote-debugging-port={port}",
            "--remote-debugging-address=127.0.0.1",
            "about:blank",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        _wait_for(port, 30)
        async with aiohttp.ClientSession() as http:
            async with http.get(f"http://127.0.0.1:{port}/json/list") as listing:
                page = next(t for t in await listing.json() if t["type"] == "page")
            async with http.ws_connect(page["webSocketDebuggerUrl"], max_msg_size=0) as ws:
                calls = 0

                async def call(method: str, **params) -> dict:
                    nonlocal calls
                    calls += 1
                    await ws.send_json({"id": calls, "method": method, "params": params})
                    while True:
                        reply = await ws.receive_json()
                        if reply.get("id") == calls:
                            return reply.get("result", {})

                await call("Page.navigate", url=url)
                await asyncio.sleep(load_seconds)
                shot = await call("Page.captureScreenshot", format="png")
        return base64.b64decode(shot["data"])
    finally:
        _stop_group(browser_proc)


def _stop_group(proc: subprocess.Popen) -> None:
    """Stop a process and every child of its group (``rerun`` launches the viewer binary; Chromium has helpers)."""
    for sig, grace in ((signal.SIGTERM, 5), (signal.SIGKILL, 5)):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        try:
            proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            pass


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("rrd", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--load-seconds", type=float, default=30.0, help="how long the page may load (default 30)")
    args = parser.parse_args(argv)
    print(screenshot(args.rrd, args.out, load_seconds=args.load_seconds))
    return 0


if __name__ == "__main__":
    sys.exit(main())
