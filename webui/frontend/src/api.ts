// JSON over HTTP to the runtime, with its error body turned into an ApiError.

import { t } from "./i18n";
import { worded, type Words } from "./i18n/words";
import { session } from "./session";

export class ApiError extends Error {
  constructor(
    message: string,
    readonly code: string,
    readonly status: number,
    readonly words: Words | null = null, // the message as the chosen language says it
  ) {
    super(message);
  }
}

export function api<T>(
  method: string,
  path: string,
  body?: unknown,
  headers: Record<string, string> = {},
): Promise<T> {
  if (body === undefined) return send<T>(method, path, undefined, headers);
  return send<T>(method, path, JSON.stringify(body), { ...headers, "content-type": "application/json" });
}

/** A body sent as it is (a file's text or bytes) with its content type. */
export function sendRaw<T>(method: string, path: string, body: BodyInit, type: string): Promise<T> {
  return send<T>(method, path, body, { "content-type": type });
}

async function send<T>(
  method: string,
  path: string,
  body: BodyInit | undefined,
  headers: Record<string, string>,
): Promise<T> {
  let response: Response;
  const sent: Record<string, string> = { ...headers };
  // A request that changes something shows the session's CSRF token (see webui/access.py).
  if (method !== "GET" && method !== "HEAD" && session.csrf) sent["x-csrf-token"] = session.csrf;
  try {
    response = await fetch(path, { method, headers: sent, body, credentials: "same-origin" });
  } catch {
    throw new ApiError(t("app.unreachable"), "unreachable", 0);
  }
  if (response.status === 401 && !path.startsWith("/api/auth/")) session.lost();
  const text = await response.text();
  const data: unknown = text ? safeParse(text) : null;
  if (!response.ok) {
    const error = (data as { error?: { code?: string; message?: string; words?: Words } } | null)
      ?.error;
    throw new ApiError(
      error?.message ?? t("app.request_failed", { status: response.status }),
      error?.code ?? "http_error",
      response.status,
      error?.words ?? null,
    );
  }
  return data as T;
}

function safeParse(text: string): unknown {
  try {
    return JSON.parse(text);
  } catch {
    return null;
  }
}

/** What went wrong, to show: a refusal of the runtime in the chosen language. */
export function errorText(err: unknown): string {
  if (err instanceof ApiError) return worded(err.message, err.words);
  return err instanceof Error ? err.message : String(err);
}
