// Orientation as people read it: roll, pitch, yaw (about fixed X, Y, Z), in degrees.

export function quaternionToRpy([x, y, z, w]: number[]): [number, number, number] {
  const roll = Math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const sinp = Math.max(-1, Math.min(1, 2 * (w * y - z * x)));
  const pitch = Math.asin(sinp);
  const yaw = Math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  const deg = (r: number) => (r * 180) / Math.PI;
  return [deg(roll), deg(pitch), deg(yaw)];
}
