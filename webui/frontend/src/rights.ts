// Controls that say which request they make, so that one the signed-in role may not use is
// shown disabled (by the gateway's own table, see session.ts) and says why where the finger
// is, before anyone fills in a form the gateway would refuse. In a template:
//   <button ${makes(request("POST", "/api/devices"))}>
// and from plain DOM code (a plugin's panel) `declare(element, [request(...)])`. The
// element keeps its own `disabled` for other reasons (busy, no control): a disabled button
// still gets pointer events, so a tap on it still says what the role lacks.

import { type ElementPart, nothing } from "lit";
import { Directive, type PartInfo, PartType, directive } from "lit/directive.js";
import { type StringKey, t } from "./i18n";
import { type Need, belowApi, session } from "./session";

export interface Request {
  method: string;
  path: string; // as api() is given it (with /api), or below /api
}

/** A request a control makes: the method (WS for a socket) and its real path. */
export function request(method: string, path: string): Request {
  return { method, path };
}

const declared = new WeakMap<HTMLElement, Request[]>();
const values = new WeakMap<HTMLElement, string>(); // a field's value before a refused touch
const GUARDED = ["pointerdown", "mousedown", "click", "keydown", "input", "change"];
const ACTIVATING = new Set([" ", "Enter", "ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight",
  "PageUp", "PageDown", "Home", "End"]);
let lastSaid = { element: null as HTMLElement | null, at: 0 };

/** Marks `element` as making `requests`: data-request names them ("POST /devices"), and
 * while the role may not make one of them it is aria-disabled and a tap says why. */
export function declare(element: HTMLElement, requests: Request[]): void {
  const named = requests.map((r) => `${r.method} ${belowApi(r.path)}`).join(", ");
  // None: the control makes no request as things are (nothing chosen for it yet).
  if (!named) delete element.dataset.request;
  else if (element.dataset.request !== named) element.dataset.request = named;
  if (!declared.has(element)) {
    for (const type of GUARDED) element.addEventListener(type, guard, true);
  }
  declared.set(element, requests);
  if (refusal(element) === null) element.removeAttribute("aria-disabled");
  else element.setAttribute("aria-disabled", "true");
}

/** What the role signed in lacks for the first of the element's requests it may not make. */
function refusal(element: HTMLElement): Need | null {
  for (const r of declared.get(element) ?? []) {
    const lacks = session.lacks(r.method, r.path);
    if (lacks !== null) return lacks;
  }
  return null;
}

// Capturing on the control itself: runs before its own handlers (and, for a hold button,
// before those inside its shadow root) and stops them.
function guard(event: Event): void {
  const element = event.currentTarget as HTMLElement;
  if (event.type === "pointerdown" && (element instanceof HTMLInputElement
    || element instanceof HTMLSelectElement)) values.set(element, element.value);
  const lacks = refusal(element);
  if (lacks === null) return;
  if (event instanceof KeyboardEvent && !ACTIVATING.has(event.key)) return; // Tab moves on
  event.preventDefault();
  event.stopImmediatePropagation();
  if (event.type === "input" || event.type === "change") {
    const before = values.get(element);
    const field = element as HTMLElement & { value?: string };
    if (before !== undefined && field.value !== undefined) field.value = before;
    return;
  }
  if (event.type === "pointerdown") {
    const touch = event as PointerEvent;
    tell(reason(element, lacks), element, touch.clientX, touch.clientY);
  } else if (event.type === "click" || event instanceof KeyboardEvent) {
    // A key, or a click no pointer began (Enter in a form, assistive technology): said at
    // the control. The click that ends a tap already said is not said twice.
    if (lastSaid.element === element && performance.now() - lastSaid.at < 1000) return;
    tell(reason(element, lacks), element);
  }
}

const ROLE_NEEDED: Record<Need, StringKey> = {
  viewer: "rights.need.viewer",
  operator: "rights.need.operator",
  programmer: "rights.need.programmer",
  admin: "rights.need.admin",
  public: "rights.need.admin",
  internal: "rights.internal",
};

/** "“Add” needs an administrator; you are signed in as an operator." */
export function reason(element: HTMLElement, lacks: Need): string {
  const role = session.me?.role ?? "viewer";
  if (lacks === "internal") return t("rights.internal");
  const params = { needed: t(ROLE_NEEDED[lacks]), role: t(`rights.as.${role}`) };
  const what = labelOf(element);
  return what ? t("rights.refused", { ...params, what }) : t("rights.refused_this", params);
}

function labelOf(element: HTMLElement): string {
  const labelled = element as HTMLElement & { labels?: NodeListOf<HTMLLabelElement> | null };
  const text = element.getAttribute("aria-label")
    || labelled.labels?.[0]?.textContent
    || element.textContent
    || element.getAttribute("label")
    || "";
  const words = text.replace(/\s+/g, " ").trim();
  return words.length > 40 ? `${words.slice(0, 39)}…` : words;
}

let tip: HTMLElement | null = null;
let hideTimer = 0;

/** Why a control did nothing, in a bubble just above where the finger touched (or above
 * the control's middle), for a few seconds. Every refusal a control meets is said this
 * way: a role's, or a hold the robot refused. */
export function tell(text: string, element: HTMLElement, x?: number, y?: number): void {
  if (!element.isConnected) return;
  if (x === undefined || y === undefined) {
    const middle = element.getBoundingClientRect();
    [x, y] = [middle.left + middle.width / 2, middle.top + middle.height / 2];
  }
  lastSaid = { element, at: performance.now() };
  if (tip === null) {
    tip = document.createElement("div");
    tip.dataset.testid = "refusal-reason";
    tip.setAttribute("role", "alert");
    Object.assign(tip.style, {
      position: "fixed",
      zIndex: "2147483647",
      maxWidth: "min(340px, calc(100vw - 16px))",
      padding: "10px 14px",
      borderRadius: "10px",
      border: "2px solid var(--warn)",
      background: "var(--raised)",
      color: "var(--text)",
      font: "600 16px/1.35 system-ui, sans-serif",
      boxShadow: "0 6px 24px rgb(0 0 0 / 35%)",
      pointerEvents: "none",
    });
  }
  tip.textContent = text;
  document.body.append(tip);
  const box = tip.getBoundingClientRect();
  const left = Math.min(Math.max(8, x - box.width / 2), window.innerWidth - box.width - 8);
  const above = y - box.height - 18;
  tip.style.left = `${left}px`;
  tip.style.top = `${above >= 8 ? above : Math.min(y + 28, window.innerHeight - box.height - 8)}px`;
  window.clearTimeout(hideTimer);
  hideTimer = window.setTimeout(hide, 4000);
}

function hide(): void {
  window.clearTimeout(hideTimer);
  tip?.remove();
}

// The next touch anywhere takes the bubble away (a refused control puts up its own again).
document.addEventListener("pointerdown", hide, true);
window.addEventListener("op-language", hide);

class MakesDirective extends Directive {
  constructor(part: PartInfo) {
    super(part);
    if (part.type !== PartType.ELEMENT) throw new Error("makes() belongs on an element");
  }

  render(..._requests: Request[]) {
    return nothing;
  }

  update(part: ElementPart, requests: Request[]) {
    declare(part.element as HTMLElement, requests);
    return nothing;
  }
}

/** The requests a control makes, on its element: `<button ${makes(request(…))}>`. */
export const makes = directive(MakesDirective);
