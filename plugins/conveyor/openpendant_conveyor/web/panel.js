// The conveyor plugin's panel: every added conveyor, live, run and stopped by touch. A plain
// custom element (no build step): the UI imports this module when the panel is first shown
// and sets `pendant` (its PendantHost) before adding the element. Device names are data:
// they are only ever set as text, never parsed as HTML.

const STYLE = `
  :host { display: block; }
  .card { background: var(--panel); border: 1px solid var(--line); border-radius: 12px;
          padding: 16px; margin-bottom: 16px; }
  h2 { margin: 0 0 12px; font-size: 20px; }
  h3 { margin: 0 0 8px; font-size: 18px; }
  .row { display: flex; flex-wrap: wrap; gap: 10px; align-items: center; margin: 10px 0; }
  .reading { min-width: 140px; }
  .value { font-size: 22px; font-variant-numeric: tabular-nums; }
  .muted { color: var(--muted); }
  button { min-height: 56px; min-width: 96px; padding: 0 18px; font-size: 17px;
           border-radius: 10px; border: 1px solid var(--line); background: var(--raised);
           color: var(--text); touch-action: manipulation; }
  button.stop { background: var(--bad, #c62828); color: #fff; border-color: transparent; }
  button:disabled { opacity: 0.45; }
  input { min-height: 52px; width: 110px; font-size: 18px; padding: 0 10px;
          border-radius: 10px; border: 1px solid var(--line); background: var(--bg);
          color: var(--text); }
  .part { display: inline-block; padding: 6px 12px; border-radius: 999px; }
  .part.yes { background: var(--ok, #2e7d32); color: #fff; }
  .part.no { border: 1px solid var(--line); }
  .error { color: var(--bad, #c62828); }
`;

class ConveyorPanel extends HTMLElement {
  constructor() {
    super();
    this.root = this.attachShadow({ mode: "open" });
    this.cards = new Map();
    this.unsubscribe = null;
  }

  connectedCallback() {
    const style = document.createElement("style");
    style.textContent = STYLE;
    this.heading = document.createElement("h2");
    this.none = document.createElement("p");
    this.none.className = "muted";
    this.none.dataset.testid = "conveyor-none";
    this.list = document.createElement("div");
    this.root.replaceChildren(style, this.heading, this.none, this.list);
    this.unsubscribe = this.pendant.subscribe(() => this.update());
    this.update();
  }

  disconnectedCallback() {
    if (this.unsubscribe) this.unsubscribe();
    this.unsubscribe = null;
  }

  update() {
    const host = this.pendant;
    this.heading.textContent = host.t("title");
    const conveyors = host.devices("conveyor");
    this.none.textContent = conveyors.length ? "" : host.t("none");
    this.none.hidden = conveyors.length > 0;
    const names = new Set(conveyors.map((d) => d.local_name));
    for (const [name, card] of this.cards) {
      if (!names.has(name)) {
        card.element.remove();
        this.cards.delete(name);
      }
    }
    for (const device of conveyors) {
      let card = this.cards.get(device.local_name);
      if (!card) {
        card = this.makeCard(device.local_name);
        this.cards.set(device.local_name, card);
        this.list.append(card.element);
      }
      this.fill(card, device);
    }
  }

  makeCard(name) {
    const host = this.pendant;
    const element = document.createElement("section");
    element.className = "card";
    element.dataset.testid = "conveyor";
    element.dataset.name = name;
    const title = document.createElement("h3");
    title.textContent = name;
    title.translate = false;
    const status = document.createElement("p");
    status.className = "muted";
    const readings = document.createElement("div");
    readings.className = "row";
    const speed = this.reading(readings, "speed");
    const travel = this.reading(readings, "travel");
    const part = document.createElement("span");
    part.dataset.testid = "conveyor-part";
    readings.append(part);

    const controls = document.createElement("div");
    controls.className = "row";
    const take = this.button(controls, "conveyor-take", () =>
      this.act(card, () =>
        host.control.holds(name) ? host.control.release(name) : host.control.take(name),
      ),
    );
    const input = document.createElement("input");
    input.type = "number";
    input.inputMode = "decimal";
    input.value = "100";
    input.min = "0";
    input.step = "10";
    input.dataset.testid = "conveyor-speed-input";
    const unit = document.createElement("span");
    unit.textContent = "mm/s";
    controls.append(input, unit);
    const speedOf = (sign) => (sign * Number(input.value || 0)) / 1000;
    const run = this.button(controls, "conveyor-run", () =>
      this.act(card, () => host.call(name, "run", { speed: speedOf(1) })),
    );
    const back = this.button(controls, "conveyor-back", () =>
      this.act(card, () => host.call(name, "run", { speed: speedOf(-1) })),
    );
    const stop = this.button(controls, "conveyor-stop", () =>
      this.act(card, () => host.call(name, "stop")),
    );
    stop.className = "stop";
    const error = document.createElement("p");
    error.className = "error";
    error.setAttribute("role", "alert");
    element.append(title, status, readings, controls, error);
    const card = { element, status, speed, travel, part, take, run, back, stop, error };
    return card;
  }

  reading(row, key) {
    const box = document.createElement("div");
    box.className = "reading";
    const label = document.createElement("div");
    label.className = "muted";
    label.dataset.key = key;
    const value = document.createElement("div");
    value.className = "value";
    value.dataset.testid = `conveyor-${key}`;
    box.append(label, value);
    row.append(box);
    return { label, value };
  }

  button(row, testid, action) {
    const button = document.createElement("button");
    button.dataset.testid = testid;
    // Pointer events: a tap on a touch screen or a click, the same.
    button.addEventListener("click", action);
    row.append(button);
    return button;
  }

  async act(card, action) {
    card.error.textContent = "";
    try {
      await action();
    } catch (err) {
      card.error.textContent = err instanceof Error ? err.message : String(err);
    }
    this.update();
  }

  fill(card, device) {
    const host = this.pendant;
    const state = host.state(device.local_name);
    const connected = device.status === "connected" && state !== null;
    const holds = host.control.holds(device.local_name);
    card.status.textContent = !connected
      ? host.t("offline")
      : device.controlled_by && !holds
        ? host.t("controlled_by", { holder: device.controlled_by })
        : "";
    card.speed.label.textContent = host.t("speed");
    card.travel.label.textContent = host.t("travel");
    card.speed.value.textContent = connected ? `${Math.round(state.speed * 1000)} mm/s` : "–";
    card.travel.value.textContent = connected
      ? `${host.length(state.position)} ${host.lengthUnit()}`
      : "–";
    const present = connected && state.part_present;
    card.part.className = `part ${present ? "yes" : "no"}`;
    card.part.dataset.present = String(present);
    card.part.textContent = host.t(present ? "part" : "no_part");
    card.take.textContent = host.t(holds ? "release" : "take");
    card.run.textContent = host.t("run");
    card.back.textContent = host.t("back");
    card.stop.textContent = host.t("stop");
    card.run.disabled = card.back.disabled = !(connected && holds);
    card.stop.disabled = !connected;
    // What each button asks the runtime: disabled, and saying why, for a role that may not.
    const path = `/api/devices/${encodeURIComponent(device.local_name)}`;
    host.declare(card.take, holds ? "DELETE" : "POST", `${path}/lease`);
    host.declare(card.run, "POST", `${path}/call/run`);
    host.declare(card.back, "POST", `${path}/call/run`);
    host.declare(card.stop, "POST", `${path}/call/stop`);
  }
}

customElements.define("op-conveyor-panel", ConveyorPanel);
