// The plugins as the runtime reports them (GET /api/plugins): what each adds, what failed to
// load, and the panels. A plugin's panel is an ES module shipped in its Python package; it is
// imported when the panel is first shown, so a plugin needs no rebuild of this UI. The module
// defines a custom element, which gets `pendant` (the PendantHost below) before it is added.

import { client, ok, type Schemas, untyped } from "./api";
import { control } from "./control";
import { language } from "./i18n";
import { feed } from "./live";
import { declare, request } from "./rights";
import { session } from "./session";
import type { AddedDevice } from "./types";
import { length, lengthUnit } from "./units";

/** A panel; `module` is where it is served, null for the panels built into this UI. */
export type PanelInfo = Schemas["PanelInfo"];
export type PluginInfo = Schemas["PluginInfo"];
export type PluginFailure = Schemas["PluginFailure"];
export type PluginReport = Schemas["PluginReport"];

/** What a plugin's panel may use of the UI. */
export interface PendantHost {
  /** JSON to the runtime (`/api/…`); errors are thrown with the runtime's message. */
  api<T>(method: string, path: string, body?: unknown, headers?: Record<string, string>): Promise<T>;
  /** Call a method a device's kind declares, with this tablet's control lease if it holds one. */
  call<T>(device: string, method: string, body?: Record<string, unknown>,
    args?: (string | number)[]): Promise<T>;
  /** The added devices (of one kind), with their status and who controls them. */
  devices(kind?: string): AddedDevice[];
  /** A device's newest state, as it streams it. */
  state<T>(device: string): T | null;
  /** Called once per drawn frame while devices or states change; returns the unsubscribe. */
  subscribe(listener: () => void): () => void;
  control: {
    holds(device: string): boolean;
    take(device: string): Promise<void>;
    release(device: string): Promise<void>;
  };
  /** Whether the role signed in may make the request (by the gateway's table of rights). */
  may(method: string, path: string): boolean;
  /** Marks a control as making the request (`path` with /api): disabled, and saying why
   * when tapped, for a role that may not; call again when it changes. `call` is a POST to
   * `/api/devices/{device}/call/{method}`, taking control a POST to `…/{device}/lease`. */
  declare(element: HTMLElement, method: string, path: string): void;
  /** The plugin's words in the language chosen ({name} filled from params). */
  t(key: string, params?: Record<string, string | number>): string;
  language(): string;
  /** A length in metres, in the unit chosen (mm or inches), and that unit. */
  length(metres: number): string;
  lengthUnit(): string;
}

export function hostFor(panel: PanelInfo): PendantHost {
  return {
    // A plugin's own routes are installed after this UI was built: not in its document.
    api: (method, path, body, headers) => untyped(method, path, body, headers),
    call: async <T>(device: string, method: string, body?: Record<string, unknown>,
      args: (string | number)[] = []) => {
      const token = control.token(device);
      // What a method answers is its kind's to say (a plugin's kind, perhaps).
      return (await ok(client.POST("/api/devices/{local_name}/call/{method}", {
        params: { path: { local_name: device, method }, header: { "X-Lease-Token": token } },
        body: { args, body: body ?? null },
      }))) as T;
    },
    devices: (kind) => feed.devices.filter((d) => kind === undefined || d.kind === kind),
    state: <T>(device: string) => (feed.states.get(device) as T | undefined) ?? null,
    subscribe: (listener) => {
      feed.addEventListener("change", listener);
      control.addEventListener("change", listener);
      return () => {
        feed.removeEventListener("change", listener);
        control.removeEventListener("change", listener);
      };
    },
    control: {
      holds: (device) => control.holds(device),
      take: (device) => control.take(device),
      release: (device) => control.release(device),
    },
    may: (method, path) => session.may(method, path),
    declare: (element, method, path) => declare(element, [request(method, path)]),
    t: (key, params) => {
      const text = panel.words[language()]?.[key] ?? panel.words.en?.[key] ?? key;
      if (!params) return text;
      return text.replace(/\{(\w+)\}/g, (whole, name: string) =>
        name in params ? String(params[name]) : whole,
      );
    },
    language,
    length: (metres) => length(metres),
    lengthUnit,
  };
}

/** The title of a plugin's panel in the language chosen. */
export function panelTitle(panel: PanelInfo): string {
  return panel.title[language()] ?? panel.title.en ?? panel.id;
}

class Plugins extends EventTarget {
  report: PluginReport | null = null;
  private loading: Promise<void> | null = null;
  private modules = new Map<string, Promise<unknown>>();

  /** Read the report (again); listeners hear "change". */
  load(): Promise<void> {
    this.loading ??= ok(client.GET("/api/plugins"))
      .then((report) => {
        this.report = report;
        this.dispatchEvent(new Event("change"));
      })
      .finally(() => {
        this.loading = null;
      });
    return this.loading;
  }

  /** Import a panel's module once; it defines the panel's element. */
  module(panel: PanelInfo): Promise<unknown> {
    const url = panel.module;
    if (url === null) return Promise.resolve();
    let loading = this.modules.get(url);
    if (!loading) {
      loading = import(/* @vite-ignore */ url);
      loading.catch(() => this.modules.delete(url)); // tried again when shown again
      this.modules.set(url, loading);
    }
    return loading;
  }
}

export const plugins = new Plugins();
