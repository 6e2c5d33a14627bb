// Builds the page's map bundle from the versions locked in package-lock.json:
//   npm ci && npm run build
// Writes ../src/aerosurvey/web/static/vendor/{olb.js, ol.css, LICENSE-ol.md, LICENSE-proj4.md, versions.json}.
import { build } from "esbuild";
import { copyFileSync, mkdirSync, readFileSync, writeFileSync } from "node:fs";

const out = new URL("../src/aerosurvey/web/static/vendor/", import.meta.url);
mkdirSync(out, { recursive: true });
const lock = JSON.parse(readFileSync(new URL("package-lock.json", import.meta.url)));
const version = (name) => lock.packages[`node_modules/${name}`].version;
const versions = { ol: version("ol"), proj4: version("proj4"), esbuild: version("esbuild") };

await build({
  entryPoints: [new URL("entry.js", import.meta.url).pathname],
  bundle: true,
  minify: true,
  format: "iife",
  globalName: "olb",
  target: "es2020",
  legalComments: "none",
  banner: { js: `/* aerosurvey map bundle: ol ${versions.ol}, proj4 ${versions.proj4}; licences in LICENSE-*.md beside this file */` },
  outfile: new URL("olb.js", out).pathname,
});
copyFileSync(new URL("node_modules/ol/ol.css", import.meta.url), new URL("ol.css", out));
copyFileSync(new URL("node_modules/ol/LICENSE.md", import.meta.url), new URL("LICENSE-ol.md", out));
copyFileSync(new URL("node_modules/proj4/LICENSE.md", import.meta.url), new URL("LICENSE-proj4.md", out));
writeFileSync(new URL("versions.json", out), JSON.stringify(versions, null, 2) + "\n");
console.log("built", versions);
