// Dark (the default, for dim cells and long shifts) or light (readable on a bright shop
// floor). The palettes are CSS custom properties on the document (index.html), which every
// component's shadow root inherits; this sets which one applies, per tablet.

export type Theme = "dark" | "light";

const KEY = "op.theme";

export function currentTheme(): Theme {
  return localStorage.getItem(KEY) === "light" ? "light" : "dark";
}

export function applyTheme(theme: Theme = currentTheme()): void {
  document.documentElement.dataset.theme = theme;
  const meta = document.querySelector('meta[name="theme-color"]');
  meta?.setAttribute("content", theme === "light" ? "#f4f6f8" : "#10161d");
}

export function setTheme(theme: Theme): void {
  localStorage.setItem(KEY, theme);
  applyTheme(theme);
  window.dispatchEvent(new Event("op-theme"));
}

/** A palette colour as the document has it now (for canvases that cannot use CSS). */
export function paletteColour(name: string): string {
  return getComputedStyle(document.documentElement).getPropertyValue(name).trim();
}
