// The cpgmatch dashboard: draws the snapshot the program sends (/events, server-sent events; /api/snapshot once
// at load) with Chart.js. Nothing here writes to the study: the server answers GET only.
'use strict';

const TERMS = ['feedback', 'distance', 'pitch', 'contact', 'periodicity'];
const TERM_COLOURS = ['#2563a8', '#e07b39', '#2f855a', '#8e44ad', '#c0392b'];
const LOG_FLOOR = 1e-3;  // the terms' log axis starts here; zeros and smaller values sit on it
// viridis, reversed: low cost (good) is bright.
const RAMP = ['#fde725', '#5ec962', '#21918c', '#3b528b', '#440154'];

let selected = null;     // study id shown in detail
let userSelected = false;
let snapshot = null;
let updates = 0;         // snapshots drawn (document.body.dataset.updates: tests read it)
const charts = {};

function el(tag, props = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(props)) {
    if (k === 'class') e.className = v; else if (k === 'dataset') Object.assign(e.dataset, v); else e[k] = v;
  }
  for (const c of children) e.append(c instanceof Node ? c : document.createTextNode(c));
  return e;
}

function num(v, digits = 4) {
  if (v === null || v === undefined || Number.isNaN(v)) return '-';
  return Math.abs(v) >= 1e4 || (v !== 0 && Math.abs(v) < 1e-3) ? v.toExponential(2) : Number(v.toPrecision(digits)).toString();
}

function ramp(t) {  // t in [0, 1] -> colour of the cost ramp (linear between stops)
  const x = Math.min(1, Math.max(0, t)) * (RAMP.length - 1);
  const i = Math.min(RAMP.length - 2, Math.floor(x));
  const f = x - i;
  const a = RAMP[i].match(/\w\w/g).map(h => parseInt(h, 16));
  const b = RAMP[i + 1].match(/\w\w/g).map(h => parseInt(h, 16));
  return `rgb(${a.map((c, k) => Math.round(c + f * (b[k] - c))).join(',')})`;
}

function drawStudies(studies) {
  const body = document.querySelector('#studies tbody');
  body.replaceChildren();
  document.getElementById('no-studies').hidden = studies.length > 0;
  for (const { state: s } of studies) {
    const bar = el('span');
    bar.style.width = `${s.budget > 0 ? Math.min(100, 100 * s.completed / s.budget) : 0}%`;
    const row = el('tr', { dataset: { study: s.study_id } },
      el('td', { class: 'num' }, String(s.study_id)),
      el('td', {}, s.name),
      el('td', { class: `state ${s.state}` }, s.state),
      el('td', { class: 'num', id: `completed-${s.study_id}` }, String(s.completed)),
      el('td', { class: 'num' }, String(s.budget)),
      el('td', {}, el('div', { class: 'bar' }, bar)),
      el('td', { class: 'num' }, num(s.best_cost)),
      el('td', { class: 'num' }, String(s.falls)),
      el('td', { class: 'num' }, String(s.in_flight)),
      el('td', { class: 'num' }, String(s.workers)),
      el('td', { class: 'num' }, num(s.rollouts_per_s, 3)),
      el('td', { class: 'msg' }, s.message || ''));
    if (s.study_id === selected) row.classList.add('selected');
    row.addEventListener('click', () => { selected = s.study_id; userSelected = true; draw(); });
    body.append(row);
  }
}

function chart(id, config) {
  if (!charts[id]) charts[id] = new Chart(document.getElementById(id), config);
  return charts[id];
}

function drawCost(study) {
  const walked = [], falls = [], minimum = [];
  const costs = study.trials.filter(t => t.ok && !t.fell && t.cost !== null).map(t => t.cost);
  // The y range is the walking costs': a fall's cost (15-19) would flatten them, so falls sit on the top edge.
  const top = costs.length ? Math.max(...costs) * 1.1 : undefined;
  const ceiling = top === undefined ? undefined : top * 1.06;  // room for the fall markers above `top`
  study.trials.forEach((t, i) => {
    if (t.ok && t.fell) falls.push({ x: t.trial_id, y: top ?? t.cost, cost: t.cost });
    else if (t.ok && t.cost !== null) walked.push({ x: t.trial_id, y: t.cost });
    if (study.current_minimum[i] !== null) minimum.push({ x: t.trial_id, y: study.current_minimum[i] });
  });
  const c = chart('chart-cost', {
    type: 'scatter',
    data: { datasets: [
      { label: 'cost', data: [], backgroundColor: '#2563a8', pointRadius: 2.5 },
      { label: 'fell', data: [], backgroundColor: '#c0392b', pointStyle: 'triangle', pointRadius: 5 },
      { label: 'current minimum', data: [], type: 'line', stepped: true, borderColor: '#1d2330', borderWidth: 2,
        pointRadius: 0 }] },
    options: {
      animation: false, maintainAspectRatio: false,
      scales: { x: { title: { display: true, text: 'rollout (trial id)' } }, y: { title: { display: true, text: 'cost' } } },
      plugins: { tooltip: { callbacks: { label: ctx => ctx.dataset.label === 'fell'
        ? `trial ${ctx.raw.x} fell: cost ${num(ctx.raw.cost)}` : `trial ${ctx.raw.x}: ${num(ctx.raw.y)}` } } } },
  });
  c.data.datasets[0].data = walked;
  c.data.datasets[1].data = falls;
  c.data.datasets[2].data = minimum;
  c.options.scales.y.max = ceiling;
  c.update('none');
}

function drawTerms(study) {
  const c = chart('chart-terms', {
    type: 'scatter',
    data: { datasets: TERMS.map((term, k) => ({ label: `J_${term}`, data: [], backgroundColor: TERM_COLOURS[k],
      pointRadius: 2 })) },
    options: {
      animation: false, maintainAspectRatio: false,
      scales: { x: { title: { display: true, text: 'rollout (trial id)' } },
                y: { type: 'logarithmic', min: LOG_FLOOR, title: { display: true, text: 'cost term' } } },
      plugins: { tooltip: { callbacks: { label: ctx => `trial ${ctx.raw.x} ${ctx.dataset.label}: ${num(ctx.raw.value)}` } } } },
  });
  TERMS.forEach((term, k) => {
    c.data.datasets[k].data = study.trials.filter(t => t.ok && t.terms && t.terms[term] !== null)
      .map(t => ({ x: t.trial_id, y: Math.max(LOG_FLOOR, t.terms[term]), value: t.terms[term] }));
  });
  c.update('none');
}

// A parameter's name on lines of about 11 characters, broken at '_' (axis labels sit side by side).
function wrap(name) {
  const lines = [];
  for (const part of name.split('_')) {
    const last = lines.length - 1;
    if (last >= 0 && lines[last].length + part.length < 11) lines[last] += `_${part}`; else lines.push(part);
  }
  return lines;
}

// The study's search space by name (its robot's names, bounds and units); {} from an older optimizer.
function axes(study) {
  const out = {};
  for (const a of study.state.search_space || []) out[a.name] = a;
  return out;
}

// A unit as the page prints it: a dimensionless parameter is a fraction of a cycle.
function unitText(unit) { return !unit || unit === '1' ? 'fraction' : unit; }

function drawParameters(study) {
  const names = study.parameters;
  const space = axes(study);
  const ran = study.trials.filter(t => t.ok && t.cost !== null && t.params);
  const key = `${study.state.study_id}:${ran.length}`;
  if (charts['chart-params'] && charts['chart-params'].$key === key) return;  // redrawn only for new trials
  const range = names.map(n => {
    const v = ran.map(t => t.params[n]).filter(x => x !== undefined);
    return [Math.min(...v), Math.max(...v)];
  });
  const walkedCosts = ran.filter(t => !t.fell).map(t => t.cost);
  const lo = Math.min(...walkedCosts), hi = Math.max(...walkedCosts);
  // Worst first, so that the best trials are drawn on top.
  const order = [...ran].sort((a, b) => (b.fell - a.fell) || (b.cost - a.cost));
  const c = chart('chart-params', {
    type: 'line',
    data: { labels: [], datasets: [] },
    options: {
      animation: false, maintainAspectRatio: false, events: [],
      plugins: { legend: { display: false }, tooltip: { enabled: false } },
      scales: { y: { min: 0, max: 1, ticks: { callback: v => (v === 0 ? 'min' : v === 1 ? 'max' : '') } },
                x: { ticks: { autoSkip: false, maxRotation: 0 } } } },
  });
  // Name, the range tried, and the unit on a line of its own (the axes' labels sit side by side).
  c.data.labels = names.map((n, i) => [...wrap(n), `${num(range[i][0], 3)} .. ${num(range[i][1], 3)}`,
    ...(space[n] ? [unitText(space[n].unit)] : [])]);
  c.data.datasets = order.map(t => ({
    data: names.map((n, i) => (range[i][1] > range[i][0] ? (t.params[n] - range[i][0]) / (range[i][1] - range[i][0]) : 0.5)),
    borderColor: t.fell ? 'rgba(120,120,120,0.45)' : ramp(hi > lo ? (t.cost - lo) / (hi - lo) : 0),
    borderDash: t.fell ? [4, 3] : [], borderWidth: t.fell ? 1 : 1.5, pointRadius: 0, tension: 0 }));
  c.$key = key;
  c.update('none');
}

function drawGait(study) {
  const state = study.state;
  const title = document.getElementById('gait-title');
  const body = document.querySelector('#gait tbody');
  body.replaceChildren();
  const rec = state.recommended_params, best = state.best_params;
  title.textContent = state.recommended_trial !== null
    ? `Recommended gait: trial ${state.recommended_trial} (GP posterior mean ${num(state.recommended_predicted_cost)})`
    : state.best_trial !== null ? `Best rollout so far: trial ${state.best_trial} (no GP recommendation yet)`
    : 'Recommended gait: none yet (no rollout has run)';
  // The search space's order (the study's own parameters), then any other name a gait carries.
  const space = axes(study);
  const given = Object.keys(rec || best || {});
  const names = [...study.parameters.filter(n => given.includes(n)), ...given.filter(n => !study.parameters.includes(n)).sort()];
  for (const n of names) {
    body.append(el('tr', {}, el('td', {}, n), el('td', {}, space[n] ? unitText(space[n].unit) : Object.keys(space).length ? 'fixed' : ''),
                   el('td', { class: 'num' }, num(rec ? rec[n] : null)),
                   el('td', { class: 'num' }, num(best ? best[n] : null))));
  }
  if (best) body.append(el('tr', {}, el('td', {}, 'cost'), el('td', {}, ''),
                                      el('td', { class: 'num' }, rec ? `${num(state.recommended_predicted_cost)} (GP mean)` : '-'),
                                      el('td', { class: 'num' }, `${num(state.best_cost)} (trial ${state.best_trial})`)));
}

// The answer trial's energy per leg, each leg under the robot's own name (any number of legs).
function drawLegs(study) {
  const legs = study.legs || [];
  const energy = study.leg_energy;
  document.getElementById('legs-title').textContent = legs.length
    ? `Legs: ${legs.length} (${legs.join(' ')})` + (energy ? ` · energy per leg of trial ${energy.trial_id} (${energy.recommended ? 'recommended' : 'best'})` : ' · no energy per leg measured yet')
    : 'Legs: not published by this optimizer';
  const body = document.querySelector('#legs tbody');
  body.replaceChildren();
  for (const l of energy ? energy.legs : []) {
    body.append(el('tr', { dataset: { leg: l.leg } }, el('td', {}, l.leg),
      el('td', { class: 'num' }, num(l.hip_positive_work_j)), el('td', { class: 'num' }, num(l.knee_positive_work_j)),
      el('td', { class: 'num' }, num(l.hip_electrical_j)), el('td', { class: 'num' }, num(l.knee_electrical_j))));
  }
  if (typeof Chart === 'undefined') return;
  const c = chart('chart-legs', {
    type: 'bar',
    data: { labels: [], datasets: [
      { label: 'hip positive work (J)', data: [], backgroundColor: '#2563a8' },
      { label: 'knee positive work (J)', data: [], backgroundColor: '#e07b39' }] },
    options: { animation: false, maintainAspectRatio: false,
      scales: { x: { title: { display: true, text: 'leg' } }, y: { beginAtZero: true, title: { display: true, text: 'J' } } } },
  });
  const rows = energy ? energy.legs : [];
  c.data.labels = rows.map(l => l.leg);
  c.data.datasets[0].data = rows.map(l => l.hip_positive_work_j);
  c.data.datasets[1].data = rows.map(l => l.knee_positive_work_j);
  c.update('none');
}

function drawDetail(study) {
  const section = document.getElementById('detail');
  section.hidden = !study;
  if (!study) return;
  const s = study.state;
  document.getElementById('detail-title').textContent =
    `Study ${s.study_id} · ${s.name} · ${s.state} · ${s.completed}/${s.budget} rollouts`;
  const message = document.getElementById('detail-message');
  message.hidden = !s.message;
  message.textContent = s.message || '';
  drawLegs(study);  // its table works without Chart.js
  if (typeof Chart === 'undefined') return;  // the tables still work without Chart.js
  drawCost(study);
  drawTerms(study);
  drawParameters(study);
  drawGait(study);
}

function drawWorkers(workers) {
  const body = document.querySelector('#workers tbody');
  body.replaceChildren();
  document.getElementById('no-workers').hidden = workers.length > 0;
  for (const w of workers) {
    const last = w.last_trial ? `study ${w.last_trial.study_id} trial ${w.last_trial.trial_id} (${w.last_trial.outcome})` : '-';
    body.append(el('tr', {},
      el('td', {}, w.worker_id), el('td', {}, w.kind), el('td', {}, w.host), el('td', { class: 'num' }, String(w.pid)),
      el('td', { class: 'num' }, String(w.slots)), el('td', { class: 'num' }, `${w.busy} of ${w.slots}`),
      el('td', { class: 'num' }, String(w.completed)),
      el('td', {}, w.accepting ? 'yes' : `no${w.status ? ': ' + w.status : ''}`), el('td', {}, last)));
  }
}

function draw() {
  if (!snapshot) return;
  const studies = snapshot.studies;
  // Follow the newest running study until the user picks one.
  if (!userSelected || !studies.some(x => x.state.study_id === selected)) {
    const running = studies.find(x => x.state.state === 'running');
    selected = (running || studies[0] || { state: {} }).state.study_id ?? null;
  }
  document.getElementById('domain').textContent = `DDS domain ${snapshot.domain}`;
  const optimizer = document.getElementById('optimizer');
  optimizer.textContent = snapshot.optimizer_heard ? 'optimizer: heard' : 'optimizer: none heard';
  optimizer.className = `pill ${snapshot.optimizer_heard ? 'good' : 'bad'}`;
  drawStudies(studies);
  drawDetail(studies.find(x => x.state.study_id === selected));
  drawWorkers(snapshot.workers);
  document.body.dataset.updates = String(++updates);
}

function receive(text) {
  snapshot = JSON.parse(text);
  draw();
}

function connect() {
  const status = document.getElementById('connection');
  const events = new EventSource('/events');
  events.addEventListener('snapshot', e => receive(e.data));
  events.onopen = () => { status.textContent = 'live'; status.className = 'pill good'; };
  // EventSource reconnects by itself (the server asks for 2 s): say so meanwhile.
  events.onerror = () => { status.textContent = 'reconnecting…'; status.className = 'pill bad'; };
}

fetch('/api/snapshot').then(r => r.text()).then(t => { if (t && !snapshot) receive(t); }).catch(() => {});
connect();
