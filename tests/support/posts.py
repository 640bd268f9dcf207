"""Two posts beside a UR5 on a table: a joint move from LEFT to RIGHT hits them unless it is
planned around them."""

from __future__ import annotations

from openpendant.runtime.bench.harness.processes import Runtime

LEFT = [1.0, -1.0, 1.8, -2.37, -1.57, 0.0]
RIGHT = [-1.0, -1.0, 1.8, -2.37, -1.57, 0.0]
SCENE = {
    "table": {"shape": "box", "size": [1.6, 1.6, 0.04], "pose": {"position": [0, 0, -0.02]}},
    "post_a": {"shape": "cylinder", "size": [0.04, 0.5], "pose": {"position": [-0.5, 0.05, 0.25]}},
    "post_b": {"shape": "cylinder", "size": [0.04, 0.5], "pose": {"position": [-0.4, -0.3, 0.25]}},
}


def put_posts(runtime: Runtime) -> None:
    for name, value in SCENE.items():
        response = runtime.api(
            "PUT", f"/variables/{name}", json={"type": "scene_object", "value": value}
        )
        response.raise_for_status()


def clear_posts(runtime: Runtime) -> None:
    for name in SCENE:
        runtime.api("DELETE", f"/variables/{name}")
