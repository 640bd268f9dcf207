// The API speaks SI units; people read millimetres and degrees.

export const deg = (rad: number): string => ((rad * 180) / Math.PI).toFixed(1);
export const mm = (m: number): string => (m * 1000).toFixed(1);

export function modeLabel(mode: string): string {
  switch (mode) {
    case "manual_reduced_speed":
      return "Manual";
    case "manual_full_speed":
      return "Manual (full speed)";
    case "auto":
      return "Automatic";
    default:
      return "Unknown mode";
  }
}

export function suggestLocalName(kind: string, taken: Set<string>): string {
  const base = /^[a-z]+$/.test(kind) ? kind : "device";
  if (!taken.has(base)) return base;
  for (let i = 2; ; i++) {
    if (!taken.has(`${base}${i}`)) return `${base}${i}`;
  }
}

export const LOCAL_NAME = /^[a-z][a-z0-9_]{0,31}$/;
