"""Run any installed driver as its own process: `openpendant driver NAME [options]`.

The host gives every driver the same start: the runtime's settings and logging, a stable
uuid (from the driver's and the device's names, unless given), the routes of its kind and
its own, and its DNS-SD advertisement. A driver's options are its `Driver.options` model,
given as flags (`--dead-zone 0.1`, lists comma-separated) or as JSON (`--options-json`, how
the launcher passes a `devices:` entry's `options`)."""

from __future__ import annotations

import argparse
import json
import os
import sys
import typing
import uuid as uuids
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

from openpendant.plugins.api import Driver, resolve
from openpendant.plugins.registry import registry
from openpendant.runtime.drivers.host import serve_driver
from openpendant.runtime.kit.app import describe_validation_errors
from openpendant.runtime.kit.device_auth import device_secret, runtime_tag, secret_path
from openpendant.runtime.kit.errors import OpenPendantError
from openpendant.runtime.kit.logs import setup_logging
from openpendant.runtime.kit.private_files import keep_private, shown_secret
from openpendant.runtime.kit.settings import SETTINGS_ENV, load_settings, settings_from_env

SECRET_ENV = "OPENPENDANT_DEVICE_SECRET"
NAMESPACE = uuids.UUID("6f1d9a52-3c39-4b61-9d0e-5c2a1f6b7e10")


class NoOptions(BaseModel):
    model_config = ConfigDict(extra="forbid")


def device_uuid(driver: str, name: str, model: str | None = None) -> str:
    """Stable across restarts, like a serial number, so the device is recognised again (with
    a `model` option, the uuid the simulated robot had before drivers were plugins)."""
    return str(uuids.uuid5(NAMESPACE, f"{driver}/{model}/{name}" if model else f"{driver}/{name}"))


def model_of(options: BaseModel) -> str | None:
    model = getattr(options, "model", None)
    return model if isinstance(model, str) and model else None


def options_model(spec: Driver) -> type[BaseModel]:
    model = resolve(spec.options) if spec.options else NoOptions
    if not (isinstance(model, type) and issubclass(model, BaseModel)):
        raise TypeError(f"{spec.options} is not a pydantic model")
    return model


def parser(spec: Driver, model: type[BaseModel]) -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=f"openpendant driver {spec.name}",
        description=f"{spec.description} ({spec.kind}), served and advertised on the network",
    )
    p.add_argument("--name", default=None, help="the device's advertised name")
    p.add_argument("--uuid", default=None, help="device uuid (default: from the name)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=0, help="0 picks a free port")
    p.add_argument("--config", type=Path, default=None, help="runtime YAML config")
    p.add_argument("--options-json", default=None, help="the options as one JSON object")
    p.add_argument(
        "--secret",
        default=None,
        help=f"the pairing secret (default: ${SECRET_ENV}, or kept in the data directory)",
    )
    for field, info in model.model_fields.items():
        flag = "--" + field.replace("_", "-")
        if info.annotation is bool:
            p.add_argument(flag, dest=field, action="store_true", default=None)
        else:
            p.add_argument(flag, dest=field, default=None, help=info.description)
    return p


def flag_value(model: type[BaseModel], field: str, text: str) -> Any:
    """A flag's text as the field wants it: lists comma-separated, integers in any base."""
    annotation = model.model_fields[field].annotation
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    if typing.get_origin(annotation) is list:
        return [v for v in text.split(",") if v]
    if annotation is int or args == [int]:
        return int(text, 0)
    return text


def run_driver(name: str, argv: list[str] | None = None) -> int:
    plugins = registry()
    spec = plugins.drivers.get(name)
    if spec is None:
        known = ", ".join(sorted(plugins.drivers)) or "none"
        print(f"openpendant driver: no driver {name!r} (installed: {known})", file=sys.stderr)
        return 2
    model = options_model(spec)
    args = vars(parser(spec, model).parse_args(argv))
    if os.environ.get(SETTINGS_ENV) and args["config"] is None:
        settings = settings_from_env()  # started by the launcher: its settings exactly
    else:
        settings = load_settings(args["config"], host=args["host"])
    setup_logging(name, settings.log_level)
    if not os.environ.get(SETTINGS_ENV):  # the launcher's children have its umask already
        keep_private(settings.data_dir)
    if spec.realtime:
        # The control loop thread must get the interpreter back within its cycle.
        sys.setswitchinterval(0.0005)
    raw = json.loads(args["options_json"]) if args["options_json"] else {}
    flags = {f: args[f] for f in model.model_fields if args.get(f) is not None}
    try:
        values = {
            f: v if isinstance(v, bool) else flag_value(model, f, v) for f, v in flags.items()
        }
        options = model.model_validate({**raw, **values})
    except (ValidationError, ValueError) as exc:
        shown = (
            describe_validation_errors(exc.errors())[0]
            if isinstance(exc, ValidationError)
            else str(exc)
        )
        print(f"openpendant driver {name}: {shown}", file=sys.stderr)
        return 2
    default = getattr(options, "default_name", None)
    device_name = args["name"] or (default() if callable(default) else name)
    try:
        driver = resolve(spec.factory)(
            device_name, args["uuid"] or device_uuid(name, device_name, model_of(options)), options
        )
    except OpenPendantError as exc:
        print(f"openpendant driver {name}: {exc.message}", file=sys.stderr)
        return 2
    routers = [resolve(spec.routes)(driver)] if spec.routes else []
    launched = bool(os.environ.get(SETTINGS_ENV))
    secret = (
        args["secret"]
        or os.environ.get(SECRET_ENV)
        or device_secret(settings.data_dir, driver.identity.uuid)
    )
    if not launched:
        # Started by hand (a board on the LAN): the administrator gives this when adding it.
        kept = secret_path(settings.data_dir, driver.identity.uuid)
        shown = (
            shown_secret(secret, kept, sys.stderr)
            if kept.is_file() and kept.read_text().strip() == secret
            else (secret if sys.stderr.isatty() else "as given (--secret or its variable)")
        )
        print(f"openpendant driver {name}: pairing code {shown}", file=sys.stderr, flush=True)
    serve_driver(
        driver,
        host=args["host"],
        port=args["port"],
        interfaces=settings.zeroconf_interfaces(),
        state_rate_hz=settings.state_rate_hz,
        ttl=settings.discovery.ttl,
        routers=routers,
        secret=secret,
        # Started by a runtime's launcher: announced as that runtime's (its data directory).
        runtime=(runtime_tag(settings.data_dir) or "") if launched else "",
    )
    return 0
