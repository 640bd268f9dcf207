import { cpSync, readFileSync, statSync } from "node:fs";
import { join, normalize } from "node:path";
import { defineConfig, type Plugin } from "vite";

// Blockly loads its cursors, sprites and icons from `media`: served from here, never a CDN.
const BLOCKLY_MEDIA = "node_modules/blockly/media";
const MEDIA_URL = "/blockly-media/";

function blocklyMedia(): Plugin {
  return {
    name: "blockly-media",
    configureServer(server) {
      server.middlewares.use(MEDIA_URL, (req, res, next) => {
        const file = join(BLOCKLY_MEDIA, normalize(req.url ?? "/").replace(/^(\.\.[/\\])+/, ""));
        if (!statSync(file, { throwIfNoEntry: false })?.isFile()) return next();
        res.end(readFileSync(file));
      });
    },
    writeBundle(options) {
      cpSync(BLOCKLY_MEDIA, join(options.dir ?? "dist", MEDIA_URL), { recursive: true });
    },
  };
}

// `npm run dev` serves the UI with hot reload and forwards /api to a running runtime.
export default defineConfig({
  plugins: [blocklyMedia()],
  // three.js and Blockly are large chunks, each loaded when its panel is first shown.
  build: { outDir: "dist", emptyOutDir: true, sourcemap: true, chunkSizeWarningLimit: 1000 },
  server: {
    proxy: { "/api": { target: "http://127.0.0.1:8080", ws: true } },
  },
});
