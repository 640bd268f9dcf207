// How many hold-to-run presses this page is keeping alive. Work that could delay their
// heartbeats (software 3D rendering) waits while any is held.

let held = 0;
const listeners = new Set<() => void>();

export function holding(): boolean {
  return held > 0;
}

export function changeHeld(delta: number): void {
  held = Math.max(0, held + delta);
  for (const listener of listeners) listener();
}

export function onHeldChange(listener: () => void): () => void {
  listeners.add(listener);
  return () => listeners.delete(listener);
}
