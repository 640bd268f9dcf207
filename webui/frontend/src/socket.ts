// WebSockets to the runtime: the URL for a path on this page's host, and the wait before a
// dropped socket tries again (doubling from 0.5 s, at most 5 s).

export function socketUrl(path: string): string {
  const scheme = location.protocol === "https:" ? "wss" : "ws";
  return `${scheme}://${location.host}${path}`;
}

export function retryDelay(attempt: number): number {
  return Math.min(500 * 2 ** attempt, 5000);
}
