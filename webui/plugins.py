"""What the UI learns about the plugins: GET /api/plugins (every plugin, what it adds, and
what failed to load, in this process or in any service), and each plugin panel's files
(GET /plugins/<plugin>/<path>, only from inside the package that declares the panel)."""

from __future__ import annotations

import asyncio
import importlib.resources
import importlib.util
from dataclasses import asdict
from pathlib import Path
from typing import Any

import httpx
from fastapi import APIRouter
from fastapi.responses import FileResponse
from pydantic import BaseModel

from openpendant.plugins.api import Panel
from openpendant.plugins.registry import Registry, registry
from openpendant.runtime.kit.errors import NotFound

PANEL_FILES = {
    ".js": "text/javascript",
    ".mjs": "text/javascript",
    ".css": "text/css",
    ".json": "application/json",
    ".svg": "image/svg+xml",
    ".png": "image/png",
}


def package_dir(package: str) -> Path | None:
    """The folder of an installed package, without importing it."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(str(importlib.resources.files(package)))


def panel_file(plugins: Registry, plugin: str, path: str) -> Path:
    """A file of a plugin's panel: inside the panel's package, of a type a page may load."""
    for panel in plugins.panels.values():
        if plugins.owner.get(("panel", panel.id)) != plugin or not panel.module:
            continue
        root = package_dir(panel.package)
        if root is None:
            continue
        target = (root / path).resolve()
        inside = target.is_relative_to(root.resolve()) and target.is_file()
        if inside and target.suffix.lower() in PANEL_FILES:
            return target
    raise NotFound(f"no file {path!r} in the panels of plugin {plugin!r}")


class PluginInfo(BaseModel):
    name: str
    description: str
    package: str
    version: str
    builtin: bool
    kinds: list[str]
    drivers: list[str]
    blocks: list[str]
    services: list[str]
    panels: list[str]


class PanelInfo(BaseModel):
    id: str
    plugin: str
    element: str  # the custom element's tag
    title: dict[str, str]  # per language
    icon: str
    module: str | None  # where the UI loads it from
    words: dict[str, dict[str, str]]  # its plugin's words, per language


class PluginFailure(BaseModel):
    plugin: str
    source: str
    error: str
    process: str  # the process it failed in


class PluginReport(BaseModel):
    """The plugins as the runtime loaded them: what each adds, what failed to load."""

    plugins: list[PluginInfo]
    panels: list[PanelInfo]
    failures: list[PluginFailure]


def describe(plugins: Registry) -> dict[str, Any]:
    panels = []
    for panel in sorted(plugins.panels.values(), key=lambda p: (p.order, p.id)):
        owner = plugins.owner.get(("panel", panel.id), "")
        panels.append(_panel(panel, owner, plugins))
    return {
        "plugins": [
            {
                "name": loaded.plugin.name,
                "description": loaded.plugin.description,
                "package": loaded.distribution,
                "version": loaded.version,
                "builtin": loaded.builtin,
                "kinds": [k.name for k in loaded.plugin.kinds],
                "drivers": [d.name for d in loaded.plugin.drivers],
                "blocks": [b.type for b in loaded.plugin.blocks],
                "services": [s.name for s in loaded.plugin.services],
                "panels": [p.id for p in loaded.plugin.panels],
            }
            for loaded in plugins.loaded
        ],
        "panels": panels,
        "failures": [{**asdict(f), "process": "webui"} for f in plugins.failures],
    }


def _panel(panel: Panel, owner: str, plugins: Registry) -> dict[str, Any]:
    plugin = next((p.plugin for p in plugins.loaded if p.plugin.name == owner), None)
    return {
        "id": panel.id,
        "plugin": owner,
        "element": panel.element,
        "title": dict(panel.title),
        "icon": panel.icon,
        "module": f"/plugins/{owner}/{panel.module}" if panel.module else None,
        "words": {lang: dict(words) for lang, words in plugin.words.items()} if plugin else {},
    }


def plugins_router(urls: dict[str, str], http: httpx.AsyncClient) -> APIRouter:
    router = APIRouter()

    @router.get("/api/plugins")
    async def plugins() -> PluginReport:
        found = describe(registry())
        names = sorted(urls)
        answers = await asyncio.gather(
            *(_failures(http, urls[name]) for name in names), return_exceptions=True
        )
        seen = {(f["plugin"], f["source"]) for f in found["failures"]}
        for name, failures in zip(names, answers, strict=True):
            if isinstance(failures, BaseException):
                continue
            for failure in failures:
                key = (failure.get("plugin"), failure.get("source"))
                if key not in seen:
                    seen.add(key)
                    found["failures"].append({**failure, "process": name})
        return PluginReport.model_validate(found)

    @router.get("/plugins/{plugin}/{path:path}")
    async def plugin_file(plugin: str, path: str) -> FileResponse:
        target = panel_file(registry(), plugin, path)
        return FileResponse(target, media_type=PANEL_FILES[target.suffix.lower()])

    return router


async def _failures(http: httpx.AsyncClient, base: str) -> list[dict[str, str]]:
    response = await http.get(f"{base}/health", timeout=1.0)
    failures = response.json().get("plugin_failures", [])
    return [f for f in failures if isinstance(f, dict)]
