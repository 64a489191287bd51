// Jobs view (#/jobs): the job table (refreshed every second), submission, cancellation, the
// retry of failed jobs and the deletion (purge) of finished ones, each offered only where the
// token's role allows it (GET /v1/whoami; docs/operations.md, "Roles").

import { api, errorText } from './api.js';
import { el, duration, integer, localTime, showError } from './format.js';

const $ = (id) => document.getElementById(id);
const ACTIVE = new Set(['queued', 'running']);

let timer = null;
let wired = false;
let me = { role: 'admin', owner: null };  // GET /v1/whoami, read on each entry

// What the token may do with job `j` (the daemon enforces it; the page only offers it).
export function allowed(who, action, j) {
  if (who.role === 'admin') return true;
  if (who.role !== 'submit') return false;
  if (action === 'submit') return true;
  if (action === 'cancel' || action === 'retry') return j.owner != null && j.owner === who.owner;
  return false;  // purge
}

export async function enterJobs(ctx) {
  if (!wired) wireForm();
  showError($('jobs-error'), '');
  me = await api.whoami();
  if (!ctx.current()) return;
  const canSubmit = allowed(me, 'submit');
  $('submit-form').hidden = !canSubmit;
  $('jobs-role').hidden = me.role === 'admin';
  $('jobs-role').textContent = canSubmit
    ? 'This token may submit jobs and cancel or retry its own (role submit).'
    : 'This token may only read (role read): no submitting, cancelling or deleting.';
  await refresh(ctx);
  if (!ctx.current()) return;
  ctx.ready('jobs');
  schedule(ctx);
}

export function leaveJobs() {
  clearTimeout(timer);
  timer = null;
}

// Next refresh one second after the previous one finished (never two at once).
function schedule(ctx) {
  clearTimeout(timer);
  timer = setTimeout(async () => {
    if (!ctx.current()) return;
    try {
      await refresh(ctx);
      showError($('jobs-error'), '');
    } catch (e) {
      showError($('jobs-error'), `could not refresh the jobs: ${errorText(e)}`);
    }
    if (ctx.current()) schedule(ctx);
  }, 1000);
}

export async function refresh(ctx) {
  const { jobs } = await api.jobs();
  if (ctx && !ctx.current()) return;
  renderTable(jobs);
}

// ---- table --------------------------------------------------------------------------------------

function renderTable(jobs) {
  const body = $('jobs-table').tBodies[0];
  const old = new Map([...body.rows].map((tr) => [tr.dataset.jobId, tr]));
  const rows = jobs.map((j) => updateRow(old.get(j.job_id) || newRow(j.job_id), j));
  const same = rows.length === body.rows.length && rows.every((r, i) => body.rows[i] === r);
  if (!same) body.replaceChildren(...rows);
  $('jobs-empty').hidden = jobs.length > 0;
}

function newRow(id) {
  const cells = ['id mono', 'site mono', 'state', 'priority num', 'progress', 'eta num', 'histories num', 'created', 'actions'];
  const tr = el('tr', { dataset: { jobId: id } }, cells.map((c) => el('td', { class: c })));
  const bar = el('span', { class: 'bar' }, el('span', { class: 'fill' }));
  tr.querySelector('td.progress').append(bar, el('span', { class: 'pct' }));
  return tr;
}

function setText(td, text) {
  if (td.textContent !== text) td.textContent = text;
}

function updateRow(tr, j) {
  const td = (c) => tr.querySelector('td.' + c);
  tr.dataset.state = j.state;
  updateIdCell(td('id'), j);
  setText(td('site'), j.site_id || 'inline');
  setText(td('state'), j.state);
  setText(td('priority'), String(j.priority));
  const pct = Math.floor(100 * (j.state === 'done' ? 1 : j.progress || 0));
  td('progress').querySelector('.fill').style.width = `${pct}%`;
  setText(td('progress').querySelector('.pct'), `${pct} %`);
  setText(td('eta'), j.state === 'running' ? duration(j.eta_s) : '—');
  setText(td('histories'), `${integer(j.histories_done)} / ${integer(j.histories_total)}`);
  setText(td('created'), localTime(j.created_utc));
  td('created').title = j.created_utc || '';
  updateActions(td('actions'), j);
  return tr;
}

function updateIdCell(cell, j) {
  const want = j.state === 'done' ? 'link' : 'text';
  if (cell.dataset.kind === want) return;
  cell.dataset.kind = want;
  cell.replaceChildren(want === 'link' ? el('a', { href: `#/jobs/${j.job_id}`, text: j.job_id }) : j.job_id);
}

// Cancel button for queued/running jobs; for finished ones an open link (done) or the error and
// a Retry button (failed), then a Delete button. Only the buttons the token's role allows.
function updateActions(cell, j) {
  const key = `${me.role}:${j.state}` + (j.error ? `:${j.error.code}:${j.error.message}` : '');
  if (cell.dataset.key === key) return;
  cell.dataset.key = key;
  const parts = [];
  if (ACTIVE.has(j.state)) {
    if (allowed(me, 'cancel', j)) parts.push(actionButton('cancel', 'Cancel', j, cancel));
    cell.replaceChildren(...parts);
    return;
  }
  if (j.state === 'done') {
    parts.push(el('a', { class: 'open', href: `#/jobs/${j.job_id}`, text: 'Open' }));
  } else if (j.state === 'failed') {
    const msg = j.error ? `${j.error.code}: ${j.error.message}` : 'failed';
    parts.push(el('span', { class: 'error job-error', text: msg }));
    if (j.error?.code !== 'invalid_input' && allowed(me, 'retry', j))
      parts.push(actionButton('retry', 'Retry', j, retry));
  }
  if (allowed(me, 'purge', j)) {
    const del = actionButton('purge', 'Delete', j, (id, b) => purge(id, j.state, b));
    del.title = 'Delete this job and all its results';
    parts.push(del);
  }
  cell.replaceChildren(...parts);
}

// A button of class `cls` for job `j` that calls onClick(job_id, the button) when clicked.
function actionButton(cls, text, j, onClick) {
  const b = el('button', { type: 'button', class: cls, text });
  b.addEventListener('click', () => onClick(j.job_id, b));
  return b;
}

// Cancel (`what` = 'cancel'), retry or delete: the button is disabled while the request is out, and
// enabled again with the error shown if it failed.
async function act(what, call, id, button) {
  button.disabled = true;
  try {
    await call(id);
    await refresh();
  } catch (e) {
    showError($('jobs-error'), `${what} ${id}: ${errorText(e)}`);
    button.disabled = false;
  }
}

const cancel = (id, button) => act('cancel', api.cancelJob, id, button);
const retry = (id, button) => act('retry', api.retryJob, id, button);

function purge(id, state, button) {
  const what = state === 'done' ? 'and all its results (files, maps, reports)' : 'and its files';
  if (!window.confirm(`Delete ${state} job ${id} ${what}? This cannot be undone.`)) return;
  act('delete', api.purgeJob, id, button);
}

// ---- submission ---------------------------------------------------------------------------------

function wireForm() {
  wired = true;
  $('submit-form').addEventListener('submit', (ev) => {
    ev.preventDefault();
    submit();
  });
}

// The submission's warnings (valid, likely not what was meant: fragments that can land beyond the
// terrain while hazardous, so that the HFD would be cut) under the form. The daemon does not
// store them, so this is the only time the page can show them. Each message names its field.
function showWarnings(warnings) {
  const list = $('submit-warnings');
  list.replaceChildren(...warnings.map((w) => {
    const severity = w.severity || 'warning';
    return el('li', { class: severity === 'note' ? 'note' : 'warning', dataset: { field: w.field || '' } },
      [el('span', { class: 'severity', text: `${severity}: ` }), w.message || '']);
  }));
  list.hidden = warnings.length === 0;
}

// The file's text is sent as it is; the form's priority is added as the top-level "priority" key
// unless the file has one (text insertion, so that numbers such as 64-bit seeds are untouched).
export function withPriority(text, priority) {
  let doc;
  try {
    doc = JSON.parse(text);
  } catch {
    return text;  // let the daemon report the malformed JSON with its line and column
  }
  if (!doc || typeof doc !== 'object' || Array.isArray(doc) || 'priority' in doc) return text;
  if (!Number.isFinite(priority) || priority === 0) return text;
  const i = text.indexOf('{');
  const rest = text.slice(i + 1);
  const sep = Object.keys(doc).length ? ', ' : '';
  return `${text.slice(0, i + 1)}"priority": ${priority}${sep}${rest}`;
}

async function submit() {
  const file = $('submit-file').files[0];
  const status = $('submit-status');
  showError($('submit-error'), '');
  status.hidden = true;
  showWarnings([]);
  if (!file) {
    showError($('submit-error'), 'choose a scenario file first');
    return;
  }
  const raw = $('submit-priority').value.trim();
  const priority = raw === '' ? 0 : Number(raw);
  const button = $('submit-button');
  button.disabled = true;
  try {
    const text = await file.text();
    const job = await api.submitJob(withPriority(text, priority));
    status.textContent = `submitted ${job.job_id} (${job.state})`;
    status.hidden = false;
    showWarnings(job.warnings || []);
    await refresh();
  } catch (e) {
    showError($('submit-error'), errorText(e));
  } finally {
    button.disabled = false;
  }
}
