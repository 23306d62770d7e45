// The REM farm page: one EventSource (/api/stream) feeds the hosts, the jobs and the open
// job; everything is written with textContent (job titles, events and tables come from
// users' applications and are never parsed as HTML).
'use strict';

let session = null;
let source = null;
let openJob = null;
let shownVersion = -1;
// Which picture of the open job is shown: 'image', or a name from its `image.views`.
let shownView = 'image';
let shownKey = '';
// The open job's last `job` event, shown again when another picture is chosen.
let lastJob = null;
const ENDED = ['finished', 'failed', 'cancelled'];
const $ = (id) => document.getElementById(id);

function el(tag, text, cls) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = String(text);
  if (cls) e.className = cls;
  return e;
}

function num(text) { return el('td', text, 'num'); }

function setStatus(text, down) {
  const s = $('status');
  s.textContent = text;
  s.classList.toggle('down', !!down);
}

function bytes(n) {
  if (!n) return '–';
  const g = n / (1024 * 1024 * 1024);
  return g >= 1 ? g.toFixed(1) + ' GiB' : (n / (1024 * 1024)).toFixed(0) + ' MiB';
}

function duration(s) {
  if (s === null || s === undefined || !isFinite(s)) return '–';
  s = Math.round(s);
  if (s < 60) return s + ' s';
  if (s < 3600) return Math.floor(s / 60) + ' min ' + (s % 60) + ' s';
  return Math.floor(s / 3600) + ' h ' + Math.floor((s % 3600) / 60) + ' min';
}

function sparkline(values) {
  const NS = 'http://www.w3.org/2000/svg';
  const w = 120, h = 24;
  const svg = document.createElementNS(NS, 'svg');
  svg.setAttribute('class', 'spark');
  svg.setAttribute('width', w);
  svg.setAttribute('height', h);
  const top = Math.max(1, ...values);
  const step = values.length > 1 ? w / (values.length - 1) : w;
  const pts = values.map((v, i) => (i * step).toFixed(1) + ',' + (h - 1 - (v / top) * (h - 2)).toFixed(1));
  const line = document.createElementNS(NS, 'polyline');
  line.setAttribute('points', pts.join(' '));
  svg.appendChild(line);
  const title = document.createElementNS(NS, 'title');
  title.textContent = 'load per core, every 2 s; top of the box: ' + top.toFixed(2);
  svg.appendChild(title);
  return svg;
}

function renderHosts(hosts) {
  const body = $('hosts').tBodies[0];
  body.replaceChildren(...hosts.map((h) => {
    const tr = el('tr');
    tr.dataset.host = h.name;
    tr.dataset.alive = h.alive;
    if (!h.alive) tr.className = 'lost';
    tr.appendChild(el('td', h.name));
    tr.appendChild(el('td', h.alive ? (h.accepting ? 'up' : 'draining') : 'lost'));
    const cpus = h.capacity && Math.abs(h.capacity - h.cores) > 0.01
      ? h.capacity.toFixed(2) + ' of ' + h.cores : String(h.cores || '–');
    tr.appendChild(num(cpus));
    tr.appendChild(num(h.alive ? h.load_per_core.toFixed(2) : '–'));
    const spark = el('td');
    spark.appendChild(sparkline(h.history));
    tr.appendChild(spark);
    tr.appendChild(num(h.alive ? Math.round(h.busy * 100) + ' %' : '–'));
    tr.appendChild(num(bytes(h.mem_free_bytes)));
    tr.appendChild(num(h.processes));
    tr.appendChild(num(h.alive ? h.slots_used + ' / ' + h.slots : '–'));
    return tr;
  }));
}

function progressBar(done, total, ended) {
  const td = el('td');
  const bar = el('div', null, ended ? 'bar ended' : 'bar');
  const fill = el('div');
  fill.style.width = (total ? Math.min(100, (100 * done) / total) : 0).toFixed(1) + '%';
  bar.appendChild(fill);
  td.appendChild(bar);
  td.appendChild(document.createTextNode(' ' + done + ' / ' + total));
  return td;
}

function renderJobs(jobs) {
  $('jobs-empty').hidden = jobs.length > 0;
  const body = $('jobs').tBodies[0];
  body.replaceChildren(...jobs.map((j) => {
    const tr = el('tr', null, 'clickable' + (j.id === openJob ? ' selected' : ''));
    tr.dataset.job = j.id;
    tr.dataset.state = j.state;
    tr.dataset.done = j.done;
    tr.dataset.total = j.total;
    tr.appendChild(el('td', j.id));
    tr.appendChild(el('td', j.title || '–'));
    tr.appendChild(el('td', j.user));
    // A job waiting for its first slot shows its place in the farm's queue.
    tr.appendChild(el('td', j.queue_position ? 'queued #' + j.queue_position : j.state));
    tr.dataset.queue = j.queue_position || '';
    tr.appendChild(progressBar(j.done, j.total, ENDED.includes(j.state)));
    tr.appendChild(num(j.lines_per_s === null ? '–' : j.lines_per_s.toFixed(1)));
    tr.appendChild(num(duration(j.eta_s)));
    tr.appendChild(num(j.workers_alive));
    tr.appendChild(num(ENDED.includes(j.state) ? '–' : j.slots));
    tr.appendChild(num(j.priority));
    tr.appendChild(el('td', j.controller_host || '–'));
    tr.appendChild(el('td', j.created_unix_ms ? new Date(j.created_unix_ms).toLocaleTimeString() : '–'));
    tr.addEventListener('click', () => open(j.id));
    return tr;
  }));
}

function renderTable(table, nodes) {
  const head = el('tr');
  (nodes.columns || []).forEach((c) => head.appendChild(el('th', c)));
  table.tHead.replaceChildren(head);
  table.tBodies[0].replaceChildren(...(nodes.rows || []).map((row) => {
    const tr = el('tr');
    row.forEach((v) => tr.appendChild(typeof v === 'number' ? num(v) : el('td', v)));
    return tr;
  }));
}

// An application's timeline (`[[step, seconds since submit], ...]`, in its order) as one line.
function timelineText(timeline) {
  if (!Array.isArray(timeline)) return '';
  const steps = timeline
    .filter((s) => Array.isArray(s) && typeof s[0] === 'string' && typeof s[1] === 'number')
    .map(([name, s]) => name + ' ' + s.toFixed(2) + ' s');
  return steps.length ? 'Timeline (seconds since submit): ' + steps.join(', ') : '';
}

function renderJob(d) {
  lastJob = d;
  const section = $('job');
  if (!d.job) {
    section.hidden = false;
    $('job-id').textContent = d.id || openJob;
    $('job-message').textContent = d.error || '';
    return;
  }
  const j = d.job;
  const p = d.published || {};
  const view = p.view || {};
  section.hidden = false;
  section.dataset.job = j.id;
  section.dataset.state = j.state;
  $('job-id').textContent = j.id;
  $('job-state').textContent = j.state;
  $('job-message').textContent = [j.title, j.message, p.problem, d.error].filter(Boolean).join(' · ');
  $('job-cancel').disabled = ENDED.includes(j.state);
  const base = '/api/jobs/' + encodeURIComponent(j.id);
  const url = base + '/image.png';
  $('job-download').href = url;
  $('job-download').setAttribute('download', j.id + '.png');
  const views = pictureViews(view.image);
  renderViewButtons(views);
  if (p.version && view.image) shownVersion = p.version;
  const key = shownVersion + ':' + shownView;
  if (p.version && view.image && key !== shownKey) {
    shownKey = key;
    const other = views.find((v) => v.name === shownView);
    $('job-image').src = (other ? base + '/view/' + other.name : url) + '?v=' + p.version;
    $('job-image').dataset.view = other ? other.name : 'image';
    const im = view.image;
    const scaled = im.png_width && im.png_width !== im.width;
    $('job-image-caption').textContent = other ? other.caption : im.width + '×' + im.height + ', ' +
      im.lines + ' of ' + im.height + ' lines' +
      (scaled ? ' (shown at ' + im.png_width + '×' + im.png_height + ')' : '');
  }
  if (view.nodes) renderTable($('nodes'), view.nodes);
  $('timeline').textContent = timelineText(view.timeline);
  const events = view.events || [];
  $('events').replaceChildren(...events.map((e) => {
    const li = el('li', new Date(e.unix_ms).toLocaleTimeString() + '  ' + e.text, e.kind);
    return li;
  }));
}

// The other pictures a job's view offers (`image.views`: [{name, caption}], at most four,
// names of lowercase letters, as REM serves them).
function pictureViews(image) {
  const list = image && Array.isArray(image.views) ? image.views : [];
  return list
    .filter((v) => v && typeof v.name === 'string' && /^[a-z]{1,16}$/.test(v.name))
    .slice(0, 4)
    .map((v) => ({ name: v.name, caption: String(v.caption || v.name).slice(0, 200) }));
}

// One button a picture ('image' and each view), the shown one pressed.
function renderViewButtons(views) {
  const box = $('job-views');
  if (!views.some((v) => v.name === shownView)) shownView = 'image';
  const names = views.length ? ['image', ...views.map((v) => v.name)] : [];
  box.replaceChildren(...names.map((name) => {
    const b = el('button', name);
    b.dataset.view = name;
    b.setAttribute('aria-pressed', String(name === shownView));
    b.onclick = () => {
      shownView = name;
      shownKey = '';
      if (lastJob) renderJob(lastJob);
    };
    return b;
  }));
}

function open(id) {
  openJob = id;
  shownVersion = -1;
  shownView = 'image';
  shownKey = '';
  history.replaceState(null, '', id ? '#job=' + encodeURIComponent(id) : '#');
  $('job').hidden = !id;
  $('job-action').textContent = '';
  connect();
}

function connect() {
  if (source) source.close();
  const url = '/api/stream' + (openJob ? '?job=' + encodeURIComponent(openJob) : '');
  source = new EventSource(url);
  source.onopen = () => setStatus('live');
  source.onerror = async () => {
    setStatus('reconnecting…', true);
    // A session that ended (logged out, daemon restarted) goes back to the login.
    const r = await fetch('/api/session').catch(() => null);
    if (r && r.status === 401) location.reload();
  };
  source.addEventListener('hosts', (e) => renderHosts(JSON.parse(e.data)));
  source.addEventListener('jobs', (e) => renderJobs(JSON.parse(e.data)));
  source.addEventListener('job', (e) => renderJob(JSON.parse(e.data)));
}

async function post(path) {
  return fetch(path, { method: 'POST', headers: { 'X-CSRF-Token': session.csrf } });
}

async function start() {
  if (new URLSearchParams(location.search).get('login') === 'failed') $('login-failed').hidden = false;
  const r = await fetch('/api/session');
  if (r.status === 401) {
    $('login').hidden = false;
    setStatus('');
    return;
  }
  session = await r.json();
  $('who').textContent = session.user + (session.admin ? ' (admin)' : '');
  $('daemon').textContent = 'via ' + session.host;
  $('app').hidden = false;
  $('logout').hidden = false;
  $('logout').addEventListener('click', async () => { await post('/logout'); location.href = '/'; });
  $('job-close').addEventListener('click', () => open(null));
  $('job-cancel').addEventListener('click', async () => {
    const res = await post('/api/jobs/' + encodeURIComponent(openJob) + '/cancel');
    const body = await res.json().catch(() => ({}));
    $('job-action').textContent = res.ok ? 'cancelled' : (body.error || res.statusText);
  });
  const m = location.hash.match(/^#job=(.+)$/);
  openJob = m ? decodeURIComponent(m[1]) : null;
  connect();
}

start();
