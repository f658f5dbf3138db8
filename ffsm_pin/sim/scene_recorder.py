"""meshcat's *static HTML* recorded in-process (:class:`SceneRecorder`).

A stand-in for meshcat's ZMQ server: it keeps the same scene tree as the server and writes the
same self-contained page as ``Visualizer.static_html()`` (the viewer's JavaScript inlined, the
scene and its animation embedded as base64 msgpack), without starting a subprocess, so the page
opens from disk in any browser with no server and no network.
"""

from __future__ import annotations

import base64
import warnings
from pathlib import Path

with warnings.catch_warnings():  # meshcat 0.3 imports pyzmq's deprecated zmq.eventloop.ioloop
    warnings.simplefilter("ignore", DeprecationWarning)
    import meshcat
    import umsgpack
    from meshcat.servers.tree import SceneTree, find_node, walk

__all__ = ["SceneRecorder"]


class SceneRecorder:
    """In-process stand-in for meshcat's ``ViewerWindow`` + ZMQ server.

    ``meshcat.Visualizer(window=SceneRecorder())`` accepts the usual calls (``set_object``,
    ``set_transform``, ``set_property``, ``set_animation``, ``delete``); they are kept in a
    scene tree exactly as meshcat's server keeps them, and :meth:`get_scene` (called by
    ``Visualizer.static_html()``) returns the self-contained HTML page.
    """

    web_url = None

    def __init__(self) -> None:
        self.tree = SceneTree()

    def send(self, command) -> None:
        """Record one meshcat command (as meshcat's visualizer would send it)."""
        data = command.lower()
        packed = umsgpack.packb(data)
        kind = data["type"]
        path = [p for p in data.get("path", "").split("/") if p]
        if kind == "delete":
            if path:
                parent = find_node(self.tree, path[:-1])
                parent.pop(path[-1], None)
            else:
                self.tree = SceneTree()
            return
        node = find_node(self.tree, path)
        if kind == "set_object":
            node.object, node.properties = packed, []
        elif kind == "set_transform":
            node.transform = packed
        elif kind == "set_property":
            node.properties.append(packed)
        elif kind == "set_animation":
            node.animation = packed
        else:  # pragma: no cover - only the commands above exist in meshcat 0.3
            raise ValueError(f"unsupported meshcat command {kind!r}")

    def get_scene(self) -> str:
        """The static HTML page (meshcat's viewer JavaScript inlined, commands embedded)."""
        commands = []
        for node in walk(self.tree):
            blobs = [node.object, *node.properties, node.transform, node.animation]
            commands += [_command_js(b) for b in blobs if b is not None]
        return _HTML.format(mainminjs=_viewer_js(), commands="".join(commands))

    def close(self) -> None:
        """Nothing to close: the recording lives in memory."""


def _command_js(blob: bytes) -> str:
    return (
        '\nfetch("data:application/octet-binary;base64,{}")\n'
        "    .then(res => res.arrayBuffer())\n"
        "    .then(buffer => viewer.handle_command_bytearray(new Uint8Array(buffer)));\n"
    ).format(base64.b64encode(blob).decode("ascii"))


_VIEWER_JS: str | None = None


def _viewer_js() -> str:
    global _VIEWER_JS
    if _VIEWER_JS is None:
        dist = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        _VIEWER_JS = dist.read_text(encoding="utf-8")
    return _VIEWER_JS


# The page meshcat's server returns for "get_scene" (meshcat 0.3), with a caption added.
_HTML = """<!DOCTYPE html>
<html>
    <head> <meta charset=utf-8> <title>ffsm-pin replay (MeshCat)</title> </head>
    <body>
        <div id="meshcat-pane">
        </div>
        <script>
            {mainminjs}
        </script>
        <script>
            var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
            {commands}
        </script>
         <style>
            body {{margin: 0; }}
            #meshcat-pane {{
                width: 100vw;
                height: 100vh;
                overflow: hidden;
            }}
        </style>
        <script id="embedded-json"></script>
    </body>
</html>
"""
