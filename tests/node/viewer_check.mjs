// Drives headless Chromium over its DevTools pipe (no npm package): opens an offline viewer.html in each state given
// (a URL hash such as "variant=red_lips&az=0"), waits for the page's #status to say "ready" (or an error), and saves
// the canvas (the page's #capture data URL) and a screenshot of the whole page. Prints a JSON report: per state the
// status and the files, and every console error, uncaught exception or failed load.
//   node viewer_check.mjs CHROMIUM PAGE.html OUT_DIR STATE...
import { spawn } from 'node:child_process';
import { mkdtempSync, rmSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, resolve } from 'node:path';

const [chrome, page, outDir, ...states] = process.argv.slice(2);
const profile = mkdtempSync(join(tmpdir(), 'viewer-check-'));
const proc = spawn(chrome, ['--headless=new', '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader',
  '--enable-unsafe-swiftshader', '--no-first-run', '--remote-debugging-pipe', `--user-data-dir=${profile}`],
  { stdio: ['ignore', 'ignore', 'ignore', 'pipe', 'pipe'] });
const pending = new Map(), errors = [];
let next = 0, buffer = '';
proc.stdio[4].on('data', chunk => {
  buffer += chunk;
  for (let at; (at = buffer.indexOf('\0')) >= 0; buffer = buffer.slice(at + 1)) {
    const m = JSON.parse(buffer.slice(0, at));
    if (m.id !== undefined && pending.has(m.id)) { pending.get(m.id)(m); pending.delete(m.id); continue; }
    if (m.method === 'Runtime.exceptionThrown') errors.push('exception: ' + m.params.exceptionDetails.exception?.description);
    if (m.method === 'Runtime.consoleAPICalled' && m.params.type === 'error')
      errors.push('console.error: ' + m.params.args.map(a => a.value ?? a.description).join(' '));
    if (m.method === 'Log.entryAdded' && m.params.entry.level === 'error') errors.push('log: ' + m.params.entry.text);
  }
});
const send = (method, params = {}, sessionId) => new Promise((done, fail) => {
  const id = ++next;
  pending.set(id, m => (m.error ? fail(new Error(`${method}: ${m.error.message}`)) : done(m.result)));
  proc.stdio[3].write(JSON.stringify({ id, method, params, ...(sessionId ? { sessionId } : {}) }) + '\0');
});
const sleep = ms => new Promise(r => setTimeout(r, ms));

const report = { states: [], errors };
try {
  const { targetId } = await send('Target.createTarget', { url: 'about:blank' });
  const { sessionId } = await send('Target.attachToTarget', { targetId, flatten: true });
  const s = (method, params) => send(method, params, sessionId);
  await s('Runtime.enable'); await s('Log.enable'); await s('Page.enable');
  await s('Emulation.setDeviceMetricsOverride', { width: 512, height: 512, deviceScaleFactor: 1, mobile: false });
  for (const [k, state] of states.entries()) {
    await s('Page.navigate', { url: `file://${resolve(page)}?load=${k}#${state}&capture` });
    let status = '';
    for (const t0 = Date.now(); Date.now() - t0 < 30000; await sleep(100)) {
      const r = await s('Runtime.evaluate', { expression: "document.getElementById('status')?.textContent ?? ''" });
      status = r.result.value;
      if (status === 'ready' || status.startsWith('error')) break;
    }
    const entry = { state, status };
    if (status === 'ready') {
      const r = await s('Runtime.evaluate', { expression: "document.getElementById('capture').textContent" });
      entry.canvas = join(outDir, `canvas_${k}.png`);
      writeFileSync(entry.canvas, Buffer.from(r.result.value.split(',')[1], 'base64'));
      const shot = await s('Page.captureScreenshot', { format: 'png' });
      entry.page = join(outDir, `page_${k}.png`);
      writeFileSync(entry.page, Buffer.from(shot.data, 'base64'));
    }
    report.states.push(entry);
  }
} catch (e) {
  errors.push('driver: ' + e.message);
}
console.log(JSON.stringify(report, null, 1));
// Browser.close lets Chromium stop its helper processes and flush the profile before it exits (a bare kill left them
// writing into it while it was removed, under load); the kill is the fallback. The profile is a temporary folder: one
// that still cannot be removed is reported, not counted against the viewer.
const exited = new Promise(r => proc.on('exit', r));
send('Browser.close').catch(() => {});
await Promise.race([exited, sleep(10000)]);
proc.kill();
await exited;
try {
  rmSync(profile, { recursive: true, force: true, maxRetries: 10, retryDelay: 200 });
} catch (e) {
  console.error(`viewer_check: could not remove the browser profile ${profile} (${e.code}); remove it by hand`);
}
