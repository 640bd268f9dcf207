// Who is signed in on this tablet: the user, their role and the session's CSRF token (sent
// with every request that changes something). The session itself is an HttpOnly cookie the
// page never sees.

export type RoleName = "viewer" | "operator" | "programmer" | "admin";
const RANK: Record<RoleName, number> = { viewer: 1, operator: 2, programmer: 3, admin: 4 };

export interface Me {
  user: string;
  role: RoleName;
  csrf: string | null;
}

export interface AuthStatus {
  set_up: boolean;
  setup_needs_code: boolean;
  signed_in: boolean;
}

class Session extends EventTarget {
  me: Me | null = null;

  get csrf(): string | null {
    return this.me?.csrf ?? null;
  }

  /** Whether the signed-in user's role is `role` or above it. */
  can(role: RoleName): boolean {
    return this.me !== null && RANK[this.me.role] >= RANK[role];
  }

  set(me: Me | null): void {
    this.me = me;
    this.dispatchEvent(new Event("change"));
  }

  /** A request was refused for want of a session (it expired, or was ended elsewhere). */
  lost(): void {
    if (this.me !== null) this.set(null);
  }
}

export const session = new Session();
