//! `listen --tui`: the GUI debug assistant's workflow in a terminal. Immediate-mode:
//! every frame is drawn from the listener's state (connections, the screen's lines).

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use ratatui::crossterm::event::{self, Event, KeyCode, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout};
use ratatui::style::{Modifier, Style};
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, List, ListItem, ListState, Paragraph};
use tokio::sync::mpsc;

use super::Shared;

struct Row {
    id: u64,
    label: String,
    live: bool,
}

pub fn run(
    shared: &Shared,
    cmds: &mpsc::Sender<Result<String, String>>,
    done: &AtomicBool,
) -> Result<(), String> {
    let mut terminal = ratatui::try_init().map_err(|e| format!("--tui needs a terminal: {e}"))?;
    let r = ui_loop(&mut terminal, shared, cmds, done);
    ratatui::restore();
    r
}

fn rows(shared: &Shared) -> Vec<Row> {
    let live = shared.conns.lock().unwrap_or_else(|p| p.into_inner());
    let screen = shared.out.screen.as_ref();
    let mut ids: Vec<u64> = live.keys().copied().collect();
    if let Some(sc) = screen {
        let sc = sc.lock().unwrap_or_else(|p| p.into_inner());
        ids.extend(sc.per_conn.keys().copied());
    }
    ids.sort_unstable();
    ids.dedup();
    ids.into_iter()
        .map(|id| match live.get(&id) {
            Some(c) => Row {
                id,
                label: format!(
                    "#{id} {} rx {} tx {}",
                    c.peer,
                    c.stats.rx_bytes.load(Ordering::Relaxed),
                    c.stats.tx_bytes.load(Ordering::Relaxed)
                ),
                live: true,
            },
            None => Row {
                id,
                label: format!("#{id} (closed)"),
                live: false,
            },
        })
        .collect()
}

fn ui_loop(
    terminal: &mut ratatui::DefaultTerminal,
    shared: &Shared,
    cmds: &mpsc::Sender<Result<String, String>>,
    done: &AtomicBool,
) -> Result<(), String> {
    let mut input = String::new();
    let mut selected: Option<u64> = None;
    // Until the user picks with Up/Down, the selection follows the newest live robot.
    let mut picked = false;
    loop {
        if done.load(Ordering::Relaxed) {
            return Ok(());
        }
        let rows = rows(shared);
        let selected_live = rows.iter().any(|r| Some(r.id) == selected && r.live);
        if selected.is_none_or(|s| !rows.iter().any(|r| r.id == s)) || (!picked && !selected_live) {
            selected = rows
                .iter()
                .rev()
                .find(|r| r.live)
                .or(rows.last())
                .map(|r| r.id);
        }
        let index = rows.iter().position(|r| Some(r.id) == selected);
        let (traffic, status) = {
            let empty = (Vec::new(), String::new());
            match shared.out.screen.as_ref() {
                Some(sc) => {
                    let sc = sc.lock().unwrap_or_else(|p| p.into_inner());
                    let t: Vec<String> = selected
                        .and_then(|id| sc.per_conn.get(&id))
                        .map(|q| q.iter().rev().take(200).rev().cloned().collect())
                        .unwrap_or_default();
                    (t, sc.general.back().cloned().unwrap_or_default())
                }
                None => empty,
            }
        };
        terminal
            .draw(|f| {
                let [main, input_area, status_area] = Layout::vertical([
                    Constraint::Min(3),
                    Constraint::Length(3),
                    Constraint::Length(1),
                ])
                .areas(f.area());
                let [list_area, traffic_area] =
                    Layout::horizontal([Constraint::Length(36), Constraint::Min(10)]).areas(main);
                let items: Vec<ListItem> =
                    rows.iter().map(|r| ListItem::new(r.label.clone())).collect();
                let list = List::new(items)
                    .block(Block::default().borders(Borders::ALL).title("robots (Up/Down)"))
                    .highlight_style(Style::default().add_modifier(Modifier::REVERSED))
                    .highlight_symbol("> ");
                let mut state = ListState::default();
                state.select(index);
                f.render_stateful_widget(list, list_area, &mut state);
                let height = traffic_area.height.saturating_sub(2) as usize;
                let shown: Vec<Line> = traffic
                    .iter()
                    .skip(traffic.len().saturating_sub(height))
                    .map(|l| Line::raw(l.clone()))
                    .collect();
                let title = match selected {
                    Some(id) => format!("#{id} traffic"),
                    None => "no robot yet".to_string(),
                };
                f.render_widget(
                    Paragraph::new(shown).block(Block::default().borders(Borders::ALL).title(title)),
                    traffic_area,
                );
                let target = selected.map(|id| format!("#{id}")).unwrap_or_else(|| "-".into());
                f.render_widget(
                    Paragraph::new(format!("> {input}")).block(
                        Block::default().borders(Borders::ALL).title(format!(
                            "send to {target}: floats 1 2 3 | line OK | text a\\r\\n | hex 02 41 03 | list | close N  (Esc quits)"
                        )),
                    ),
                    input_area,
                );
                f.render_widget(Paragraph::new(status.clone()), status_area);
            })
            .map_err(|e| format!("terminal: {e}"))?;
        if !event::poll(Duration::from_millis(100)).map_err(|e| format!("terminal: {e}"))? {
            continue;
        }
        let Event::Key(key) = event::read().map_err(|e| format!("terminal: {e}"))? else {
            continue;
        };
        if key.kind != KeyEventKind::Press {
            continue;
        }
        match key.code {
            KeyCode::Esc => return Ok(()),
            KeyCode::Char('c') if key.modifiers.contains(KeyModifiers::CONTROL) => return Ok(()),
            KeyCode::Up => {
                picked = true;
                if let Some(i) = index {
                    selected = rows.get(i.saturating_sub(1)).map(|r| r.id);
                }
            }
            KeyCode::Down => {
                picked = true;
                if let Some(i) = index {
                    selected = rows
                        .get((i + 1).min(rows.len().saturating_sub(1)))
                        .map(|r| r.id);
                }
            }
            KeyCode::Enter => {
                let line = std::mem::take(&mut input);
                let line = line.trim();
                if line.is_empty() {
                    continue;
                }
                let is_command = line.starts_with('@')
                    || line == "list"
                    || line == "help"
                    || line.starts_with("close ");
                let cmd = match selected {
                    Some(id) if !is_command => format!("@{id} {line}"),
                    _ => line.to_string(),
                };
                let _ = cmds.blocking_send(Ok(cmd));
            }
            KeyCode::Backspace => {
                input.pop();
            }
            KeyCode::Char(c) => input.push(c),
            _ => {}
        }
    }
}
