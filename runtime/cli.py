"""The `openpendant` command."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from openpendant.runtime import __version__


def _run(args: argparse.Namespace) -> int:
    from openpendant.runtime.kit.logs import setup_logging
    from openpendant.runtime.kit.settings import load_settings
    from openpendant.runtime.launcher.run import run

    settings = load_settings(
        args.config,
        host=args.host,
        port=args.port,
        data_dir=args.data_dir,
        sim=False if args.no_sim else None,
    )
    if args.tls:
        settings = settings.model_copy(
            update={"tls": settings.tls.model_copy(update={"enabled": True})}
        )
    setup_logging("launcher", settings.log_level, human=True)
    return run(settings, entry=main)


def _service(args: argparse.Namespace) -> int:
    import sys

    from openpendant.runtime.kit.settings import settings_from_env
    from openpendant.runtime.services import all_services, run_service

    if args.name not in all_services():
        known = ", ".join(sorted(all_services()))
        print(
            f"openpendant service: no service {args.name!r} (installed: {known})", file=sys.stderr
        )
        return 2
    settings = settings_from_env()
    if args.data_dir is not None:
        settings = settings.model_copy(update={"data_dir": args.data_dir})
    run_service(
        args.name,
        fd=args.fd,
        host=args.host,
        port=args.port,
        settings=settings,
        public_fd=args.public_fd,
        redirect_fd=args.redirect_fd,
    )
    return 0


def _driver(name: str, rest: list[str]) -> int:
    from openpendant.runtime.drivers.run import run_driver

    return run_driver(name, rest)


def _bench(args: argparse.Namespace) -> int:
    from openpendant.runtime.bench.runner import main

    return main(only=args.only, json_path=args.json)


def _openapi(args: argparse.Namespace) -> int:
    from openpendant.webui.openapi import write

    write(args.out)
    return 0


def _token(args: argparse.Namespace) -> int:
    from openpendant.runtime.auth.setup import create_token
    from openpendant.runtime.kit.errors import OpenPendantError
    from openpendant.runtime.kit.settings import load_settings

    data_dir = args.data_dir or load_settings(args.config).data_dir
    try:
        print(create_token(data_dir, args.role, args.name))
    except (OpenPendantError, ValueError) as exc:
        print(f"openpendant token create: {exc}", file=sys.stderr)
        return 2
    return 0


def _device(args: argparse.Namespace) -> int:
    from openpendant.runtime.drivers.device_file import run_device_file

    return run_device_file(args.file)


def _install_service(args: argparse.Namespace) -> int:
    from openpendant.runtime.launcher.install_service import install_service

    return install_service(args.root, args.driver, runtime=args.runtime, enable=args.enable)


def _backup(args: argparse.Namespace) -> int:
    from openpendant.runtime.kit.settings import load_settings
    from openpendant.runtime.launcher.backup import BackupError, backup, scheduled_backup

    settings = load_settings(args.config)
    data_dir = args.data_dir or settings.data_dir
    output = args.output or Path(f"openpendant-backup-{time.strftime('%Y%m%d-%H%M%S')}.tar.gz")
    try:
        if args.scheduled:
            folder = settings.backups.folder
            if folder is None:
                raise BackupError("give backups: {folder: DIR} in the config for --scheduled")
            output = scheduled_backup(data_dir, folder, settings.backups.keep_days, args.config)
        else:
            backup(data_dir, output, args.config)
    except (BackupError, OSError) as exc:
        print(f"openpendant backup: {exc}", file=sys.stderr)
        return 2
    print(f"backed up {data_dir} to {output}")
    return 0


def _restore(args: argparse.Namespace) -> int:
    from openpendant.runtime.kit.settings import load_settings
    from openpendant.runtime.launcher.backup import BackupError, restore

    data_dir = args.data_dir or load_settings(args.config).data_dir
    try:
        kept = restore(args.file, data_dir)
    except (BackupError, OSError) as exc:
        print(f"openpendant restore: {exc}", file=sys.stderr)
        return 2
    print(f"restored {args.file} into {data_dir}; what was there is kept in {kept}")
    return 0


def _doctor(args: argparse.Namespace) -> int:
    from openpendant.runtime.kit.settings import load_settings
    from openpendant.runtime.launcher.doctor import doctor

    overrides = {"data_dir": args.data_dir, "port": args.port, "host": args.host}
    return doctor(load_settings(args.config, **overrides))


def _drivers(rest: list[str]) -> int:
    if not rest or rest[0].startswith("-"):
        from openpendant.plugins.registry import registry

        print("openpendant driver NAME [--help | options]; installed drivers:")
        for name, spec in sorted(registry().drivers.items()):
            print(f"  {name:16} {spec.kind:9} {spec.description}")
        return 0 if rest[:1] in (["--list"], ["-h"], ["--help"]) else 2
    return _driver(rest[0], rest[1:])


def _data_options(command: argparse.ArgumentParser, config_help: str = "site config YAML") -> None:
    """Which runtime's data a command works on: its config, or its data directory."""
    command.add_argument("--config", type=Path, default=None, help=config_help)
    command.add_argument("--data-dir", type=Path, default=None, help="the runtime's data")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="openpendant", description="OpenPendant teach pendant")
    p.add_argument("--version", action="version", version=f"openpendant {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="start the runtime (services + simulated robot)")
    run.add_argument("--port", type=int, default=None, help="UI port (default 8080)")
    run.add_argument("--host", default=None, help="UI address (default 127.0.0.1)")
    run.add_argument("--config", type=Path, default=None, help="site config YAML")
    run.add_argument("--data-dir", type=Path, default=None, help="database and logs")
    run.add_argument("--no-sim", action="store_true", help="start no simulated robot")
    run.add_argument(
        "--tls", action="store_true", default=None, help="serve the UI over HTTPS (config: tls)"
    )
    run.set_defaults(handler=_run)

    sub.add_parser(
        "driver", help="run an installed driver (driver NAME --help; driver --list)", add_help=False
    )
    sub.add_parser("sim-robot", help="the same as driver sim-robot", add_help=False)
    sub.add_parser("spacemouse", help="the same as driver spacemouse", add_help=False)

    device = sub.add_parser(
        "device", help="serve one device described by a file (a driver board's one command)"
    )
    device.add_argument("file", type=Path, help="YAML: driver, name, host, port, options")
    device.set_defaults(handler=_device)

    install = sub.add_parser(
        "install-service", help="write (and enable) systemd units for the runtime and drivers"
    )
    install.add_argument(
        "--root", type=Path, default=Path("/"), help="install below this folder (default /)"
    )
    install.add_argument(
        "--driver",
        action="append",
        default=[],
        metavar="DRIVER:NAME",
        help="a device served by its own unit (repeatable), e.g. modbus-gripper:gripper",
    )
    install.add_argument(
        "--no-runtime",
        dest="runtime",
        action="store_false",
        help="only the drivers (a driver board)",
    )
    install.add_argument(
        "--no-enable", dest="enable", action="store_false", help="write the units only"
    )
    install.set_defaults(handler=_install_service)

    saved = sub.add_parser(
        "backup", help="one archive of the databases, device secrets and config (online)"
    )
    saved.add_argument("--output", type=Path, default=None, help="the archive to write")
    _data_options(saved, config_help="site config YAML (kept too)")
    saved.add_argument(
        "--scheduled",
        action="store_true",
        help="into the config's backups.folder, removing those older than backups.keep_days",
    )
    saved.set_defaults(handler=_backup)
    back = sub.add_parser("restore", help="put a backup in place (the runtime stopped)")
    back.add_argument("file", type=Path, help="an archive made by openpendant backup")
    _data_options(back)
    back.set_defaults(handler=_restore)

    check = sub.add_parser(
        "doctor", help="check this computer for a cell: data, ports, multicast, clock, devices"
    )
    _data_options(check)
    check.add_argument("--port", type=int, default=None, help="UI port (default 8080)")
    check.add_argument("--host", default=None, help="UI address")
    check.set_defaults(handler=_doctor)

    service = sub.add_parser("service", help="run one service (the launcher does this)")
    service.add_argument("name", help="the service's name")
    service.add_argument("--fd", type=int, default=None, help="inherited listening socket")
    service.add_argument(
        "--public-fd", type=int, default=None, help="inherited public socket (jog: its socket)"
    )
    service.add_argument(
        "--redirect-fd", type=int, default=None, help="inherited plain-HTTP socket (webui, TLS)"
    )
    service.add_argument("--host", default="127.0.0.1")
    service.add_argument("--port", type=int, default=None)
    service.add_argument("--data-dir", type=Path, default=None)
    service.set_defaults(handler=_service)

    token = sub.add_parser("token", help="API tokens for scripts (token create --help)")
    token_sub = token.add_subparsers(dest="action", required=True)
    create = token_sub.add_parser(
        "create", help="print a new API token (run on the runtime computer)"
    )
    create.add_argument(
        "--role", required=True, choices=["viewer", "operator", "programmer", "admin"]
    )
    create.add_argument("--name", required=True, help="what the token is for")
    _data_options(create)
    create.set_defaults(handler=_token)

    openapi = sub.add_parser(
        "openapi", help="print the API's OpenAPI document (every service, below /api)"
    )
    openapi.add_argument("--out", type=Path, default=None, help="write it here instead")
    openapi.set_defaults(handler=_openapi)

    bench = sub.add_parser("bench", help="run the benchmarks (runtime/bench)")
    bench.add_argument(
        "--only",
        action="append",
        default=None,
        metavar="NAME",
        help="run only this benchmark or figure (repeatable)",
    )
    bench.add_argument("--json", type=Path, default=None, help="write the figures here")
    bench.set_defaults(handler=_bench)
    return p


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] in (["sim-robot"], ["spacemouse"]):
        return _driver(argv[0], argv[1:])
    if argv[:1] == ["driver"]:
        return _drivers(argv[1:])
    args = parser().parse_args(argv)
    return int(args.handler(args))


if __name__ == "__main__":
    sys.exit(main())
