"""The four roles, each with every right of the ones below it."""

from __future__ import annotations

from enum import IntEnum


class Role(IntEnum):
    viewer = 1  # watch
    operator = 2  # jog, run saved programs, answer prompts, take control
    programmer = 3  # edit programs, waypoints, the scene, tools, calibrations
    admin = 4  # users, devices, safety settings, network

    @classmethod
    def named(cls, name: str) -> Role:
        try:
            return cls[name]
        except KeyError:
            known = ", ".join(r.name for r in cls)
            raise ValueError(f"no role {name!r} (roles: {known})") from None
