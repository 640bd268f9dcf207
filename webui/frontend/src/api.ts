// The runtime's API, typed from its OpenAPI document: src/generated/api.d.ts, which `make ui`
// generates from the services' own models (webui/openapi.py, openapi-typescript). A call
// that does not fit a route's path, parameters, body or answer does not compile:
//   const details = await ok(client.GET("/api/devices/{local_name}",
//     { params: { path: { local_name: name } } }));
// Errors are thrown as an ApiError with the runtime's message (and its words).

import createClient from "openapi-fetch";
import type { components, paths } from "./generated/api";
import { t } from "./i18n";
import { worded, type Words } from "./i18n/words";
import { session } from "./session";

/** The runtime's models, by the names its services give them. */
export type Schemas = components["schemas"];

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

export const client = createClient<paths>({ credentials: "same-origin" });

client.use({
  onRequest({ request }) {
    // A request that changes something shows the session's CSRF token (see webui/access.py).
    if (request.method !== "GET" && request.method !== "HEAD" && session.csrf) {
      request.headers.set("x-csrf-token", session.csrf);
    }
    return request;
  },
  onResponse({ request, response }) {
    if (response.status === 401 && !new URL(request.url).pathname.startsWith("/api/auth/")) {
      session.lost();
    }
    return response;
  },
});

/** What a call answered, or an ApiError: the runtime's refusal, or unreachable. */
export async function ok<T>(
  pending: Promise<{ data?: T; error?: unknown; response: Response }>,
): Promise<T> {
  let result: { data?: T; error?: unknown; response: Response };
  try {
    result = await pending;
  } catch {
    throw new ApiError(t("app.unreachable"), "unreachable", 0);
  }
  if (!result.response.ok) throw refusal(result.response.status, result.error);
  return result.data as T;
}

function refusal(status: number, body: unknown): ApiError {
  const error = (body as { error?: { code?: string; message?: string; words?: Words } } | null)
    ?.error;
  return new ApiError(
    error?.message ?? t("app.request_failed", { status }),
    error?.code ?? "http_error",
    status,
    error?.words ?? null,
  );
}

/** JSON to a route the core's document does not know: a plugin's (plugins.ts), whose routes
 * are installed after the UI was built. The same headers and errors as `client`. */
export async function untyped<T>(
  method: string,
  path: string,
  body?: unknown,
  headers: Record<string, string> = {},
): Promise<T> {
  const sent: Record<string, string> = { ...headers };
  if (body !== undefined) sent["content-type"] = "application/json";
  if (method !== "GET" && method !== "HEAD" && session.csrf) sent["x-csrf-token"] = session.csrf;
  let response: Response;
  try {
    response = await fetch(path, {
      method,
      headers: sent,
      body: body === undefined ? undefined : JSON.stringify(body),
      credentials: "same-origin",
    });
  } catch {
    throw new ApiError(t("app.unreachable"), "unreachable", 0);
  }
  if (response.status === 401) session.lost();
  const text = await response.text();
  const data: unknown = text ? safeParse(text) : null;
  if (!response.ok) throw refusal(response.status, data);
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
