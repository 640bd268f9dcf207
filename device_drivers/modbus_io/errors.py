"""What a Modbus device's refusals mean, for the person who has to fix them."""

from __future__ import annotations

from openpendant.runtime.kit.errors import OpenPendantError, Unavailable


class ModbusRefused(OpenPendantError):
    """The device answered with a Modbus exception."""

    status = 502
    code = "modbus_exception"


# Modbus application protocol 1.1b3, section 7.
EXCEPTIONS: dict[int, tuple[str, str]] = {
    1: ("illegal_function", "the device does not support this function"),
    2: ("illegal_data_address", "the device has no such address: check the register map"),
    3: ("illegal_data_value", "the device refused the value or the count asked for"),
    4: ("device_failure", "the device failed while doing it: check the device"),
    5: ("acknowledge", "the device accepted it but is still working on it: try again later"),
    6: ("device_busy", "the device is busy with a long command: try again later"),
    7: ("negative_acknowledge", "the device cannot do this function now"),
    8: ("memory_parity_error", "the device found a parity error in its memory: check it"),
    10: ("gateway_path_unavailable", "the gateway has no path to that unit id: check unit_id"),
    11: ("gateway_target_failed", "the device behind the gateway did not answer: check it"),
}


def refused(exception_code: int, what: str) -> ModbusRefused:
    code, meaning = EXCEPTIONS.get(
        exception_code, (f"exception_{exception_code}", "an exception code Modbus does not define")
    )
    return ModbusRefused(
        f"{what}: Modbus exception {exception_code} ({code.replace('_', ' ')}): {meaning}",
        code=f"modbus_{code}",
        details={"exception_code": exception_code},
    )


def no_answer(what: str, why: str) -> Unavailable:
    return Unavailable(f"{what}: the device did not answer ({why})", code="device_timeout")
