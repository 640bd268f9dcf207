// The panels of the app: those built into this UI, and each plugin's (GET /api/plugins). The
// built-in ones register through the plugin API too (webui/plugin.py), which sets their order;
// until the runtime has answered, they show in their usual order.
import { html, svg, type SVGTemplateResult, type TemplateResult } from "lit";
import { t } from "../i18n";
import { icons } from "../icons";
import { type PanelInfo, panelTitle, plugins } from "../plugins";
import "./devices-panel";
import "./io-panel";
import "./jog-panel";
import "./plugin-panel";
import "./program-panel";
import "./scene-panel";
import "./system-panel";
import "./users-panel";
import "./vision-panel";

export interface Panel {
  id: string;
  /** The name in the nav, in the chosen language. */
  title: () => string;
  icon: SVGTemplateResult;
  render: () => TemplateResult;
}

const builtIn: Record<string, Panel> = {
  jog: {
    id: "jog",
    title: () => t("app.panel.jog"),
    icon: icons.jog,
    render: () => html`<op-jog-panel></op-jog-panel>`,
  },
  program: {
    id: "program",
    title: () => t("app.panel.program"),
    icon: icons.program,
    render: () => html`<op-program-panel></op-program-panel>`,
  },
  scene: {
    id: "scene",
    title: () => t("app.panel.scene"),
    icon: icons.scene,
    render: () => html`<op-scene-panel></op-scene-panel>`,
  },
  io: {
    id: "io",
    title: () => t("app.panel.io"),
    icon: icons.io,
    render: () => html`<op-io-panel></op-io-panel>`,
  },
  vision: {
    id: "vision",
    title: () => t("app.panel.vision"),
    icon: icons.vision,
    render: () => html`<op-vision-panel></op-vision-panel>`,
  },
  devices: {
    id: "devices",
    title: () => t("app.panel.devices"),
    icon: icons.devices,
    render: () => html`<op-devices-panel></op-devices-panel>`,
  },
  system: {
    id: "system",
    title: () => t("app.panel.system"),
    icon: icons.system,
    render: () => html`<op-system-panel></op-system-panel>`,
  },
  users: {
    id: "users",
    title: () => t("app.panel.users"),
    icon: icons.users,
    render: () => html`<op-users-panel></op-users-panel>`,
  },
};

/** Panels only some roles see in the navigation (their page still says why not to others). */
export const ADMIN_PANELS = new Set(["users"]);

function pluginPanel(info: PanelInfo): Panel {
  return {
    id: info.id,
    title: () => panelTitle(info),
    icon: svg`<svg viewBox="0 0 24 24" width="28" height="28" fill="none" stroke="currentColor"
      stroke-width="2" stroke-linecap="round" stroke-linejoin="round" aria-hidden="true"
      ><path d=${info.icon || "M4 4h16v16H4z"} /></svg>`,
    render: () => html`<op-plugin-panel .panel=${info}></op-plugin-panel>`,
  };
}

/** The panels in the order the runtime gives them. */
export function panels(): Panel[] {
  const report = plugins.report;
  if (report === null) return Object.values(builtIn);
  return report.panels.flatMap((info) => {
    if (info.module === null) return builtIn[info.id] ? [builtIn[info.id]] : [];
    return [pluginPanel(info)];
  });
}
