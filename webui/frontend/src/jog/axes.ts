// What the Jog panel's keys jog: the mode (joints, or Cartesian in the base or the tool
// frame), the step of an incremental jog, and the value each row of keys shows.

import { t } from "../i18n";
import type { JogAxis } from "../components/jog-pad";
import { conjugate, multiply, quaternionToRpy, rotate } from "../math";
import type { Pose, RobotState } from "../types";
import { angle, angleText, angleWithUnit, length, lengthUnit, lengthWithUnit, radians } from "../units";

export type Mode = "joint" | "base" | "tool";
export type Stepping = "continuous" | "fine" | "coarse";
export const MODES: Mode[] = ["joint", "base", "tool"];
export const STEPPINGS: Stepping[] = ["continuous", "fine", "coarse"];
export const MODE_LABEL = { joint: "jog.joints", base: "jog.base", tool: "jog.tool" } as const;
const CARTESIAN = ["x", "y", "z", "rx", "ry", "rz"];
const RAD = Math.PI / 180;
// Incremental steps: fine = 0.1 mm / 0.1°, coarse = 1 mm / 1°.
export const STEP = {
  fine: { linear: 0.0001, angular: 0.1 * RAD },
  coarse: { linear: 0.001, angular: RAD },
};

/** A step size in the chosen units to two significant digits: "1 mm", "0.1°", "0.039 in". */
export function stepLabel(size: { linear: number; angular: number }): string {
  const short = (text: string): string => String(Number(Number(text).toPrecision(2)));
  const turn = short(angle(size.angular, 6));
  return t("jog.step", {
    length: `${short(length(size.linear, 6))} ${lengthUnit()}`,
    angle: angleText(turn),
  });
}

/** The step of a key held in this mode (undefined: continuous), in m or rad. */
export function stepOf(stepping: Stepping, mode: Mode, axis: string): number | undefined {
  if (stepping === "continuous") return undefined;
  const size = STEP[stepping];
  const linear = mode !== "joint" && ["x", "y", "z"].includes(axis);
  return linear ? size.linear : size.angular;
}

/** The rows of keys and what each shows. In the tool frame, readings count along the tool's
 * own axes from where the TCP was when Tool was chosen: reset() when it is chosen (again). */
export class JogAxes {
  private toolZero: Pose | null = null;

  reset(): void {
    this.toolZero = null;
  }

  axes(mode: Mode, joints: number, state: RobotState | undefined): JogAxis[] {
    if (mode === "joint") {
      return Array.from({ length: joints }, (_, i) => ({
        key: String(i),
        label: t("jog.joint_short", { number: i + 1 }),
        value: state ? angleWithUnit(state.joint_position[i]) : "–",
      }));
    }
    if (!state) return CARTESIAN.map((a) => ({ key: a, label: a.toUpperCase(), value: "–" }));
    let [x, y, z] = state.tcp_pose.position;
    let rpy = quaternionToRpy(state.tcp_pose.orientation);
    if (mode === "tool") {
      this.toolZero ??= state.tcp_pose;
      const back = conjugate(this.toolZero.orientation);
      const p = this.toolZero.position;
      [x, y, z] = rotate(back, [0, 1, 2].map((i) => state.tcp_pose.position[i] - p[i]));
      rpy = quaternionToRpy(multiply(back, state.tcp_pose.orientation));
    }
    const values = [
      ...[x, y, z].map((v) => lengthWithUnit(v)),
      ...rpy.map((a) => angleWithUnit(radians(a))),
    ];
    return CARTESIAN.map((a, i) => ({ key: a, label: a.toUpperCase(), value: values[i] }));
  }
}
