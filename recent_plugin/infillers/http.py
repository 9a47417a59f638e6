"""JSON over HTTP to OpenAI-compatible servers, with errors that name the server and the path."""

from __future__ import annotations

import json
import urllib.error
import urllib.request


def post_json(base_url: str, path: str, body: dict, *, api_key: str | None = None, timeout_s: float = 60.0) -> dict:
    headers = {"Content-Type": "application/json"}
    if api_key:
        headers["Authorization"] = f"Bearer {api_key}"
    url = base_url.rstrip("/") + path
    request = urllib.request.Request(url, data=json.dumps(body).encode(), headers=headers, method="POST")
    try:
        with urllib.request.urlopen(request, timeout=timeout_s) as response:
            return json.loads(response.read())
    except urllib.error.HTTPError as exc:
        raise RuntimeError(f"{url} answered {exc.code}: {exc.read()[:300]!r}") from None
    except urllib.error.URLError as exc:
        raise RuntimeError(f"cannot reach the server at {base_url}: {exc.reason}") from None
    except json.JSONDecodeError as exc:
        raise RuntimeError(f"{url} did not answer JSON: {exc}") from None
