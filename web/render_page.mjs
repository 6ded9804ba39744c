// Opens a page in headless Chromium through the DevTools protocol and waits, in real time, until
// its title starts with the prefix given, then prints the title and writes the data URL the page
// left in <pre id="png"> as a PNG. A page that is slow to load (a large module, SwiftShader under
// load) is waited for rather than cut off, as --virtual-time-budget can cut it.
// Usage: node render_page.mjs URL TITLE_PREFIX OUT.png W H [SECONDS]
import { spawn } from 'node:child_process';
import { existsSync, mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import WebSocket from 'ws';

const [url, prefix, out, w, h, seconds = '120'] = process.argv.slice(2);
const profile = mkdtempSync(join(tmpdir(), 'aniso-chromium-'));
const chromium = spawn('chromium', ['--headless=new', '--no-sandbox', '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader', `--user-data-dir=${profile}`, `--window-size=${w},${h}`,
  '--remote-debugging-port=0', 'about:blank'],
  { stdio: ['ignore', 'ignore', 'pipe'], detached: true });
// Chromium and its helper processes (its own process group) killed and waited for, then the
// profile removed: a helper still writing into it would leave it behind in the temporary folder.
const finish = async (code, message) => {
  if (message) console.log(message);
  const exited = new Promise((resolve) => chromium.once('exit', resolve));
  try { process.kill(-chromium.pid, 'SIGKILL'); } catch { chromium.kill('SIGKILL'); }
  await Promise.race([exited, new Promise((resolve) => setTimeout(resolve, 5000))]);
  for (let i = 0; i < 20 && existsSync(profile); ++i) {
    rmSync(profile, { recursive: true, force: true });
    await new Promise((resolve) => setTimeout(resolve, 100));
  }
  process.exit(code);
};
setTimeout(() => finish(1, '<title>timed out</title>'), Number(seconds) * 1000);

const browser = await new Promise((resolve) => {
  let text = '';
  chromium.stderr.on('data', (d) => {
    text += d;
    const m = text.match(/DevTools listening on (ws:\/\/\S+)/);
    if (m) resolve(m[1]);
  });
});
const port = new URL(browser).port;
const target = await (await fetch(`http://127.0.0.1:${port}/json/new?${encodeURIComponent(url)}`,
                                  { method: 'PUT' })).json();
const ws = new WebSocket(target.webSocketDebuggerUrl);
ws.on('error', () => {});  // the browser killed at the end
await new Promise((resolve) => ws.on('open', resolve));
let id = 0;
const pending = new Map();
ws.on('message', (data) => {
  const msg = JSON.parse(data);
  if (pending.has(msg.id)) pending.get(msg.id)(msg.result), pending.delete(msg.id);
});
const evaluate = (expression) => new Promise((resolve) => {
  pending.set(++id, (r) => resolve(r && r.result ? r.result.value : undefined));
  ws.send(JSON.stringify({ id, method: 'Runtime.evaluate', params: { expression } }));
});
for (;;) {
  const title = await evaluate('document.title');
  if (typeof title === 'string' && title.startsWith(prefix)) {
    const png = await evaluate("(document.getElementById('png') || {}).textContent || ''");
    if (png.startsWith('data:image/png;base64,'))
      writeFileSync(out, Buffer.from(png.slice('data:image/png;base64,'.length), 'base64'));
    await finish(0, `<title>${title}</title>`);
  }
  await new Promise((r) => setTimeout(r, 200));
}
