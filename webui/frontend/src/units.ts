// The API speaks SI units (metres, radians); people read the units they chose on the System
// panel: millimetres or inches, degrees or radians, on this tablet only. Values typed into a
// field are in the same units and go back to SI here.

export type LengthUnit = "mm" | "in";
export type AngleUnit = "deg" | "rad";

const LENGTHS: Record<LengthUnit, { perMetre: number; label: string; digits: number }> = {
  mm: { perMetre: 1000, label: "mm", digits: 1 },
  in: { perMetre: 1000 / 25.4, label: "in", digits: 3 },
};
const ANGLES: Record<AngleUnit, { perRadian: number; label: string; digits: number }> = {
  deg: { perRadian: 180 / Math.PI, label: "°", digits: 1 },
  rad: { perRadian: 1, label: "rad", digits: 3 },
};
const LENGTH_KEY = "op.units.length";
const ANGLE_KEY = "op.units.angle";

export const units = {
  length: (localStorage.getItem(LENGTH_KEY) === "in" ? "in" : "mm") as LengthUnit,
  angle: (localStorage.getItem(ANGLE_KEY) === "rad" ? "rad" : "deg") as AngleUnit,
};

export function setUnits(length: LengthUnit, angle: AngleUnit): void {
  units.length = length;
  units.angle = angle;
  localStorage.setItem(LENGTH_KEY, length);
  localStorage.setItem(ANGLE_KEY, angle);
  window.dispatchEvent(new Event("op-units"));
}

/** "mm" or "in". */
export const lengthUnit = (): string => LENGTHS[units.length].label;
/** "°" or "rad". */
export const angleUnit = (): string => ANGLES[units.angle].label;

/** A length in metres as text in the chosen unit, without the unit ("12.5"). */
export function length(metres: number, digits = LENGTHS[units.length].digits): string {
  return (metres * LENGTHS[units.length].perMetre).toFixed(digits);
}

/** A length in metres with its unit ("12.5 mm", "0.492 in"). */
export const lengthWithUnit = (metres: number): string => `${length(metres)} ${lengthUnit()}`;

/** An angle in radians as text in the chosen unit, without the unit ("90.0"). */
export function angle(radians: number, digits = ANGLES[units.angle].digits): string {
  return (radians * ANGLES[units.angle].perRadian).toFixed(digits);
}

/** A number already in the chosen angle unit, with that unit ("90.0°", "1.571 rad"). */
export const angleText = (number: string): string =>
  units.angle === "deg" ? `${number}°` : `${number} rad`;

/** An angle in radians with its unit ("90.0°", "1.571 rad"). */
export const angleWithUnit = (radians: number): string => angleText(angle(radians));

/** A distance at a glance, with its unit: whole millimetres, or inches to 0.01. */
export const roughLength = (metres: number): string =>
  `${length(metres, units.length === "mm" ? 0 : 2)} ${lengthUnit()}`;

/** A field's value for a length in metres, rounded as people type it. */
export function lengthToField(metres: number): number {
  const scale = 10 ** LENGTHS[units.length].digits;
  return Math.round(metres * LENGTHS[units.length].perMetre * scale) / scale;
}

/** Metres from a field's value in the chosen unit. */
export const lengthFromField = (value: number): number => value / LENGTHS[units.length].perMetre;

/** A field's value for an angle in radians, rounded as people type it. */
export function angleToField(radians: number): number {
  const scale = 10 ** ANGLES[units.angle].digits;
  return Math.round(radians * ANGLES[units.angle].perRadian * scale) / scale;
}

/** Radians from a field's value in the chosen unit. */
export const angleFromField = (value: number): number => value / ANGLES[units.angle].perRadian;

/** The step of a field in the chosen length unit (1 mm, 0.01 in). */
export const lengthFieldStep = (): number => (units.length === "mm" ? 1 : 0.01);
/** The step of a field in the chosen angle unit (1°, 0.01 rad). */
export const angleFieldStep = (): number => (units.angle === "deg" ? 1 : 0.01);

const RAD_PER_DEG = Math.PI / 180;
/** Degrees (as math.ts gives roll, pitch, yaw) to radians, for the functions above. */
export const radians = (degrees: number): number => degrees * RAD_PER_DEG;
/** Radians to degrees, as math.ts takes roll, pitch, yaw. */
export const degrees = (radians: number): number => radians / RAD_PER_DEG;

/** How a field reads and is typed: its unit, its step, and its number each way from SI. */
export interface FieldScale {
  unit: () => string;
  step: () => number;
  toField: (value: number) => number;
  fromField: (value: number) => number;
}

export const LENGTH_FIELD: FieldScale = {
  unit: lengthUnit,
  step: lengthFieldStep,
  toField: lengthToField,
  fromField: lengthFromField,
};

export const ANGLE_FIELD: FieldScale = {
  unit: angleUnit,
  step: angleFieldStep,
  toField: angleToField,
  fromField: angleFromField,
};

/** A value rounded as its field shows it: saving stores what was shown, changed or not. */
export const asShown = (scale: FieldScale, value: number): number =>
  scale.fromField(scale.toField(value));
