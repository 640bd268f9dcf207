import { defineConfig } from "vite";

// `npm run dev` serves the UI with hot reload and forwards /api to a running runtime.
export default defineConfig({
  build: { outDir: "dist", emptyOutDir: true, sourcemap: true },
  server: {
    proxy: { "/api": { target: "http://127.0.0.1:8080", ws: true } },
  },
});
