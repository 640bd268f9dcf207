// Orientation as people read it: roll, pitch, yaw (about fixed X, Y, Z), in degrees.

export function quaternionToRpy([x, y, z, w]: number[]): [number, number, number] {
  const roll = Math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y));
  const sinp = Math.max(-1, Math.min(1, 2 * (w * y - z * x)));
  const pitch = Math.asin(sinp);
  const yaw = Math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
  const deg = (r: number) => (r * 180) / Math.PI;
  return [deg(roll), deg(pitch), deg(yaw)];
}

/** The quaternion [x, y, z, w] of roll, pitch, yaw in degrees (about fixed X, Y, Z). */
export function rpyToQuaternion(
  rollDeg: number,
  pitchDeg: number,
  yawDeg: number,
): [number, number, number, number] {
  const half = Math.PI / 360;
  const [cr, sr] = [Math.cos(rollDeg * half), Math.sin(rollDeg * half)];
  const [cp, sp] = [Math.cos(pitchDeg * half), Math.sin(pitchDeg * half)];
  const [cy, sy] = [Math.cos(yawDeg * half), Math.sin(yawDeg * half)];
  return [
    sr * cp * cy - cr * sp * sy,
    cr * sp * cy + sr * cp * sy,
    cr * cp * sy - sr * sp * cy,
    cr * cp * cy + sr * sp * sy,
  ];
}

type Quaternion = number[]; // [x, y, z, w]

export function multiply([ax, ay, az, aw]: Quaternion, [bx, by, bz, bw]: Quaternion): Quaternion {
  return [
    aw * bx + ax * bw + ay * bz - az * by,
    aw * by - ax * bz + ay * bw + az * bx,
    aw * bz + ax * by - ay * bx + az * bw,
    aw * bw - ax * bx - ay * by - az * bz,
  ];
}

export function conjugate([x, y, z, w]: Quaternion): Quaternion {
  return [-x, -y, -z, w];
}

/** The vector v turned by the unit quaternion q. */
export function rotate(q: Quaternion, [vx, vy, vz]: number[]): number[] {
  const [x, y, z] = multiply(multiply(q, [vx, vy, vz, 0]), conjugate(q));
  return [x, y, z];
}
