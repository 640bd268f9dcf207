// Who is signed in on this tablet: the user, their role and the session's CSRF token (sent
// with every request that changes something), and the gateway's table of rights (webui/
// policy.py, read at sign-in) that says what the role may do. The session itself is an
// HttpOnly cookie the page never sees.

import { ApiError, client, ok, type Schemas } from "./api";
import type { Words } from "./i18n/words";

export type RoleName = Schemas["SignedIn"]["role"];
const RANK: Record<RoleName, number> = { viewer: 1, operator: 2, programmer: 3, admin: 4 };

/** What a request needs: a role, anyone ("public"), or only the runtime's own services. */
export type Need = Schemas["Policy"]["otherwise"];

/** Who signed in (GET /api/auth/me; signing in answers it but for `via`). */
export type Me = Schemas["SignedIn"];
export type AuthStatus = Schemas["AuthStatus"];

interface Rule {
  methods: Set<string>;
  pattern: RegExp;
  need: Need;
}

/** A path as the table reads it: below /api, without its query, percent-decoded (as the
 * gateway sees it). */
export function belowApi(path: string): string {
  let below = path.split("?")[0];
  if (below === "/api" || below.startsWith("/api/")) below = below.slice(4) || "/";
  try {
    return decodeURIComponent(below);
  } catch {
    return below;
  }
}

/** Why a session ended, as the gateway said it. */
export interface Ended {
  message: string;
  words: Words | null;
}

class Session extends EventTarget {
  me: Me | null = null;
  /** Why the last session ended (shown on the sign-in screen until the next sign-in). */
  ended: Ended | null = null;
  private checking: Promise<void> | null = null; // asking the gateway why, under way
  private rules: Rule[] | null = null; // null: not read (the gateway decides alone)
  private otherwise: Need = "admin";
  private changes = 0;

  get csrf(): string | null {
    return this.me?.csrf ?? null;
  }

  /** Whether the signed-in user's role is `role` or above it. */
  can(role: RoleName): boolean {
    return this.me !== null && RANK[this.me.role] >= RANK[role];
  }

  /** What a request needs by the gateway's table: the first rule naming its method and
   * path; null while the table is not known. `path` with or without its /api. */
  needOf(method: string, path: string): Need | null {
    if (this.rules === null) return null;
    const below = belowApi(path);
    const rule = this.rules.find((r) => r.methods.has(method) && r.pattern.test(below));
    return rule ? rule.need : this.otherwise;
  }

  /** The need the signed-in role falls short of for this request; null if it may (or the
   * table could not be read: then the gateway's answer says). */
  lacks(method: string, path: string): Need | null {
    const need = this.needOf(method, path);
    if (need === null || need === "public") return null;
    if (need === "internal") return need;
    return this.can(need) ? null : need;
  }

  may(method: string, path: string): boolean {
    return this.lacks(method, path) === null;
  }

  /** Signed in (with the table of rights read first, so nothing shows before it is known)
   * or out. */
  async set(me: Me | null): Promise<void> {
    const change = ++this.changes;
    const rules = me === null ? null : await readPolicy();
    if (change !== this.changes) return; // signed out (or in again) meanwhile
    if (me !== null) this.ended = null;
    this.rules = rules?.rules ?? null;
    this.otherwise = rules?.otherwise ?? "admin";
    this.me = me;
    this.dispatchEvent(new Event("change"));
  }

  /** A request or a socket was refused for want of a session (it expired, or was ended
   * elsewhere). The gateway is asked why, and whether it did end: a socket may also close
   * for a ticket of its own while the session stands. */
  lost(): Promise<void> {
    if (this.me === null) return Promise.resolve();
    this.checking ??= whyEnded().then(async (ended) => {
      this.checking = null;
      if (ended === undefined || this.me === null) return;
      this.ended = ended;
      await this.set(null);
    });
    return this.checking;
  }
}

/** Why the session ended, as the gateway says it; undefined while it stands or the gateway
 * cannot say (restarting, unreachable: the next refusal asks again). */
async function whyEnded(): Promise<Ended | undefined> {
  try {
    await ok(client.GET("/api/auth/me"));
    return undefined;
  } catch (err) {
    if (!(err instanceof ApiError) || err.status !== 401) return undefined;
    return { message: err.message, words: err.words };
  }
}

async function readPolicy(): Promise<{ rules: Rule[]; otherwise: Need } | null> {
  try {
    const policy = await ok(client.GET("/api/auth/policy"));
    return {
      rules: policy.rules.map((r) => ({
        methods: new Set(r.methods),
        pattern: new RegExp(r.pattern),
        need: r.need,
      })),
      otherwise: policy.otherwise,
    };
  } catch {
    return null;
  }
}

export const session = new Session();
