"""A register map: which coil, input or register holds each named signal, how it is coded,
and in which unit it is read (loaded from YAML)."""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import Field, ValidationError, model_validator

from openpendant.device_drivers.modbus_io.codec import DataType, Order, word_count
from openpendant.device_drivers.modbus_io.link import Table
from openpendant.runtime.interfaces.common import Strict
from openpendant.runtime.interfaces.io import SIGNAL_NAME, SignalInfo, SignalKind
from openpendant.runtime.kit.bounded_yaml import load_yaml
from openpendant.runtime.kit.errors import InvalidValue

KIND: dict[Table, SignalKind] = {
    "coil": "digital_output",
    "discrete_input": "digital_input",
    "input_register": "analog_input",
    "holding_register": "analog_output",
}
# The most one read may ask for (Modbus application protocol, 6.1-6.4).
MAX_READ: dict[Table, int] = {
    "coil": 2000,
    "discrete_input": 2000,
    "input_register": 125,
    "holding_register": 125,
}


class Register(Strict):
    name: str = Field(pattern=SIGNAL_NAME)
    table: Table
    address: int = Field(ge=0, le=65535)
    type: DataType | None = None  # bool for coils and discrete inputs; else uint16 unless said
    scale: float = Field(default=1.0, allow_inf_nan=False)
    offset: float = Field(default=0.0, allow_inf_nan=False)
    unit: str = Field(default="", max_length=16)
    minimum: float | None = None
    maximum: float | None = None
    description: str = Field(default="", max_length=200)

    @model_validator(mode="after")
    def _coded(self) -> Register:
        bits = self.table in ("coil", "discrete_input")
        if self.type is None:
            self.type = "bool" if bits else "uint16"
        if bits != (self.type == "bool"):
            holds = "a bool" if bits else "a number"
            raise ValueError(f"{self.name}: a {self.table} holds {holds}")
        if self.scale == 0:
            raise ValueError(f"{self.name}: scale 0 would lose every value")
        if self.address + self.words > 65536:
            raise ValueError(f"{self.name}: runs past address 65535")
        return self

    @property
    def data_type(self) -> DataType:
        assert self.type is not None
        return self.type

    @property
    def words(self) -> int:
        return 1 if self.type == "bool" else word_count(self.data_type)

    @property
    def kind(self) -> SignalKind:
        return KIND[self.table]

    def signal(self) -> SignalInfo:
        return SignalInfo(
            name=self.name,
            kind=self.kind,
            unit=self.unit,
            minimum=self.minimum,
            maximum=self.maximum,
            description=self.description,
        )


class RegisterMap(Strict):
    model: str = Field(default="Modbus I/O", max_length=64)
    unit_id: int = Field(default=1, ge=0, le=247)
    byte_order: Order = "big"
    word_order: Order = "big"
    signals: list[Register] = Field(min_length=1, max_length=1024)

    @model_validator(mode="after")
    def _distinct(self) -> RegisterMap:
        names = [s.name for s in self.signals]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"signals named twice: {', '.join(twice)}")
        taken: dict[tuple[str, int], str] = {}
        for s in self.signals:
            for a in range(s.address, s.address + s.words):
                other = taken.setdefault((s.table, a), s.name)
                if other != s.name:
                    raise ValueError(f"{s.name} and {other} share {s.table} {a}")
        return self

    def named(self, name: str) -> Register:
        for s in self.signals:
            if s.name == name:
                return s
        raise KeyError(name)

    def blocks(self) -> list[tuple[Table, int, int]]:
        """(table, first address, count): the reads that fetch every signal, each within the
        protocol's limit, gaps of up to 16 unused addresses read through."""
        found: list[tuple[Table, int, int]] = []
        for table in KIND:
            spans = sorted(
                (s.address, s.address + s.words) for s in self.signals if s.table == table
            )
            start: int | None = None
            end = 0
            for first, stop in spans:
                if start is not None and first - end <= 16 and stop - start <= MAX_READ[table]:
                    end = max(end, stop)
                    continue
                if start is not None:
                    found.append((table, start, end - start))
                start, end = first, stop
            if start is not None:
                found.append((table, start, end - start))
        return found


def load_map(path: Path) -> RegisterMap:
    try:
        data = load_yaml(path.read_text())
        return RegisterMap.model_validate(data)
    except (OSError, yaml.YAMLError, ValidationError) as exc:
        raise InvalidValue(f"register map {path}: {exc}") from exc
