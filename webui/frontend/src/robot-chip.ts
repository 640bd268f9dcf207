// What a robot's chip in the safety bar says, and in which colour. The link comes first: a
// robot whose states no longer come is in no mode this page can vouch for, so a stale or
// lost link (or the runtime itself out of reach) is what the chip says. Then what stops the
// robot (the same order as the Jog panel's card), then whether it is enabled, and only then
// its operational mode.

import { faultOf } from "./components/robot-fault";
import { modeLabel } from "./format";
import { type StringKey, t } from "./i18n";
import type { AddedDevice, ConnectionStatus, RobotState } from "./types";

export type ChipLevel = "ok" | "warn" | "bad" | "idle";

export interface ChipState {
  level: ChipLevel;
  /** The one word the chip shows after the robot's name. */
  text: string;
  /** Said on a long press or hover: the driver's or the link's own words. */
  detail: string;
  disabled: boolean;
}

const LINK: Record<ConnectionStatus, StringKey> = {
  connected: "devices.status.connected",
  connecting: "devices.status.connecting",
  stale: "devices.status.stale",
  disconnected: "devices.status.disconnected",
};

export function chipState(
  device: AddedDevice,
  state: RobotState | undefined,
  online: boolean,
): ChipState {
  const chip = (level: ChipLevel, text: string, detail = "", disabled = false): ChipState => ({
    level,
    text,
    detail,
    disabled,
  });
  if (!online) return chip("bad", t("app.link.unknown"), t("app.runtime_offline"));
  switch (faultOf(device, state)) {
    case "link":
      return chip(device.status === "connecting" ? "warn" : "bad", t(LINK[device.status]),
        device.last_error);
    case "estop":
      return chip("bad", t("app.estop"));
    case "protective_stop":
      return chip("bad", t("app.protective_stop"), state?.error_message ?? "");
    case "controller":
      return chip("bad", t("app.error"), t("fault.controller.title", { robot: device.local_name }));
    case "error":
      return chip("bad", t("app.error"), state?.error_message ?? "");
    case null:
      break;
  }
  if (!state) return chip("warn", t(LINK.connected)); // its first state is on its way
  const mode = modeLabel(state.operational_mode);
  return state.flags.enabled ? chip("ok", mode) : chip("idle", mode, "", true);
}
