import { defineConfig } from "vite";

// `npm run dev` serves the UI with hot reload and forwards /api to a running runtime.
export default defineConfig({
  // three.js is one large chunk, loaded only when a 3D view is first shown.
  build: { outDir: "dist", emptyOutDir: true, sourcemap: true, chunkSizeWarningLimit: 800 },
  server: {
    proxy: { "/api": { target: "http://127.0.0.1:8080", ws: true } },
  },
});
