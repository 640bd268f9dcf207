// Control leases as this browser tab holds them: one holder name per device (kept across
// reloads), one token per robot (kept for this tab only), renewed while held.

import { ApiError, client, ok } from "./api";
import { t } from "./i18n";
import { type Request, request } from "./rights";

const RENEW_EVERY_MS = 5000;


const HOLDER_KEY = "op.holder";
export const HOLDER_MAX = 40;

function holderName(): string {
  let name = localStorage.getItem(HOLDER_KEY);
  if (!name) {
    name = `Pendant ${Math.random().toString(16).slice(2, 6).toUpperCase()}`;
    localStorage.setItem(HOLDER_KEY, name);
  }
  return name;
}

/** What a control that takes (or gives back) control of a device asks the runtime. */
export function leaseRequest(device: string, giveBack = false): Request {
  return giveBack
    ? request("DELETE", `/api/devices/${encodeURIComponent(device)}/lease`)
    : request("POST", `/api/devices/${encodeURIComponent(device)}/lease`);
}

export class Control extends EventTarget {
  /** The name others see while this tablet has control ("Controlled by …"). */
  get holder(): string {
    return holderName();
  }

  /** A name people chose for this tablet, e.g. "Cell 2 pendant"; leases held carry it on
   * their next renewal. */
  rename(name: string): void {
    const clean = name.replace(/[\p{Cc}\p{Cf}]/gu, "").trim().slice(0, HOLDER_MAX);
    if (!clean) throw new Error(t("jog.control.needs_name"));
    localStorage.setItem(HOLDER_KEY, clean);
    this.dispatchEvent(new Event("change"));
  }
  private timers = new Map<string, number>();
  // Counts releases per robot: an answer to a take or renewal sent before a release must
  // not put the token back (the tablet would hold control it was told it gave up).
  private releases = new Map<string, number>();

  token(robot: string): string | null {
    return sessionStorage.getItem(`op.lease.${robot}`);
  }

  holds(robot: string): boolean {
    return this.token(robot) !== null;
  }

  async take(robot: string): Promise<void> {
    const token = this.token(robot);
    const asked = this.releases.get(robot) ?? 0;
    const granted = await ok(client.POST("/api/devices/{local_name}/lease", {
      params: { path: { local_name: robot }, header: { "X-Lease-Token": token } },
      body: { holder: this.holder },
    }));
    if ((this.releases.get(robot) ?? 0) !== asked) {
      // Released while this was on its way: give the lease back, keep nothing.
      await this.giveBack(robot, granted.token);
      return;
    }
    sessionStorage.setItem(`op.lease.${robot}`, granted.token);
    this.keepAlive(robot);
    this.dispatchEvent(new Event("change"));
  }

  async release(robot: string): Promise<void> {
    const token = this.token(robot);
    this.releases.set(robot, (this.releases.get(robot) ?? 0) + 1);
    this.forget(robot);
    if (token) await this.giveBack(robot, token);
  }

  private async giveBack(robot: string, token: string): Promise<void> {
    await ok(client.DELETE("/api/devices/{local_name}/lease", {
      params: { path: { local_name: robot }, header: { "X-Lease-Token": token } },
    })).catch(() => undefined);
  }

  /** The server no longer honours our token (it lapsed, or the robot was removed). */
  forget(robot: string): void {
    sessionStorage.removeItem(`op.lease.${robot}`);
    window.clearInterval(this.timers.get(robot));
    this.timers.delete(robot);
    this.dispatchEvent(new Event("change"));
  }

  resume(robot: string): void {
    if (this.holds(robot) && !this.timers.has(robot)) this.keepAlive(robot);
  }

  private keepAlive(robot: string): void {
    window.clearInterval(this.timers.get(robot));
    const timer = window.setInterval(() => {
      this.take(robot).catch((err: unknown) => {
        // Refused (409) or the robot gone (404): the lease is lost. No answer, or a service
        // not answering (5xx, e.g. while the runtime restarts): the lease may well be alive
        // (leases outlive restarts), so the token is kept and renewed on the next round.
        if (err instanceof ApiError && err.status >= 400 && err.status < 500) this.forget(robot);
      });
    }, RENEW_EVERY_MS);
    this.timers.set(robot, timer);
  }
}

export const control = new Control();
