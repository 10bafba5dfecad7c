//! `listen --tui`: the GUI debug assistant's workflow in a terminal. Immediate-mode:
//! every frame is drawn from the listener's state (connections, the screen's lines) and
//! the UI's own few fields ([`Ui`]).
//!
//! Long lines wrap (by display width) instead of being cut. The traffic pane is a
//! scrollback of the selected robot's lines (bounded by [`out::SCREEN_LINES`] lines and
//! [`out::SCREEN_BYTES`] bytes per connection): PgUp/PgDn/Home/End scroll it, and while it
//! is scrolled back new lines do not move the view; the title counts them. The mouse
//! wheel scrolls it too once F12 turns mouse capture on; it is off at start on purpose:
//! capturing the mouse takes away the terminal's own text selection, which is how a line
//! is copied out of the traffic (F12 again gives it back).

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use ratatui::crossterm::event::{
    self, DisableMouseCapture, EnableMouseCapture, Event, KeyCode, KeyEvent, KeyEventKind,
    KeyModifiers, MouseEventKind,
};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Modifier, Style};
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Clear, List, ListItem, ListState, Paragraph};
use ratatui::Frame;
use tokio::sync::mpsc;
use unicode_width::UnicodeWidthChar;

use super::{out, Shared};

/// Snippets with a key of their own: F2 sends the first, ..., F9 the eighth.
const SNIPPET_KEYS: u8 = 8;
/// Lines one notch of the mouse wheel scrolls.
const WHEEL_LINES: u64 = 3;

/// Rows of the status area: the newest general lines (notes, warnings), wrapped.
const STATUS_ROWS: usize = 4;

/// One robot of the robots' list: live connections and closed ones with kept traffic.
struct Row {
    id: u64,
    label: String,
    live: bool,
}

/// What the UI remembers between frames.
#[derive(Default)]
struct Ui {
    input: String,
    selected: Option<u64>,
    /// Until the user picks with Up/Down, the selection follows the newest live robot.
    picked: bool,
    help: bool,
    help_scroll: u16,
    /// Scrolled back: the traffic pane ends before line number `back` of the selected
    /// robot's scrollback ([`out::Scrollback::total`] numbering). `None`: follows the end.
    back: Option<u64>,
    /// Whole lines shown in the traffic pane at the last frame (one page).
    page: u64,
    /// F12: the mouse is captured (the wheel scrolls the traffic).
    mouse: bool,
    /// Rows and columns of the traffic pane at the last frame.
    height: usize,
    width: usize,
}

/// Runs the UI in the terminal until Esc or Ctrl+C, or until the listener is `done`;
/// typed lines and snippet keys go to `cmds`. The terminal is restored however it ends.
pub fn run(
    shared: &Shared,
    cmds: &mpsc::Sender<Result<String, String>>,
    done: &AtomicBool,
) -> Result<(), String> {
    let mut terminal = ratatui::try_init().map_err(|e| format!("--tui needs a terminal: {e}"))?;
    let r = ui_loop(&mut terminal, shared, cmds, done);
    // Whether or not F12 turned it on: the shell gets its mouse back.
    let _ = ratatui::crossterm::execute!(std::io::stdout(), DisableMouseCapture);
    ratatui::restore();
    r
}

/// The robots' list: every live connection and every closed one whose traffic is kept,
/// by connection number.
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

/// `line` cut into rows of at most `width` display columns (at least one row; a
/// character wider than the width gets a row of its own).
fn wrap(line: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut rows = vec![String::new()];
    let mut used = 0;
    for c in line.chars() {
        let w = c.width().unwrap_or(0);
        if used + w > width && used > 0 {
            rows.push(String::new());
            used = 0;
        }
        if let Some(last) = rows.last_mut() {
            last.push(c);
        }
        used += w;
    }
    rows
}

/// The end of `line` that fits in `width` display columns.
fn tail(line: &str, width: usize) -> &str {
    let mut used = 0;
    for (i, c) in line.char_indices().rev() {
        used += c.width().unwrap_or(0);
        if used > width {
            return &line[i + c.len_utf8()..];
        }
    }
    line
}

/// The traffic pane's rows: the lines before `end` (a line number), as many as fit in
/// `height` rows of `width`, the newest at the bottom (the top line may show only its
/// last rows). Returns the rows and how many lines are shown whole.
fn traffic_rows(sb: &out::Scrollback, end: u64, width: usize, height: usize) -> (Vec<String>, u64) {
    let first = sb.first();
    let end = end.clamp(first, sb.total);
    let before = usize::try_from(end - first).unwrap_or(usize::MAX);
    bottom_rows(sb.lines.iter().take(before), width, height)
}

/// The last of `lines`, wrapped to `width`, as many as fit in `height` rows (the top one
/// may show only its last rows), and how many lines are shown whole.
fn bottom_rows<'a>(
    lines: impl DoubleEndedIterator<Item = &'a String>,
    width: usize,
    height: usize,
) -> (Vec<String>, u64) {
    let mut rows: Vec<String> = Vec::new();
    let mut whole = 0;
    for line in lines.rev() {
        if rows.len() >= height {
            break;
        }
        let mut wrapped = wrap(line, width);
        if rows.len() + wrapped.len() <= height {
            whole += 1;
        }
        wrapped.extend(rows);
        rows = wrapped;
    }
    let cut = rows.len().saturating_sub(height);
    (rows.split_off(cut), whole)
}

/// How many lines from line number `start` on fit whole in `height` rows of `width`
/// (at least one).
fn fit_from(sb: &out::Scrollback, start: u64, width: usize, height: usize) -> u64 {
    let skip = usize::try_from(start.saturating_sub(sb.first())).unwrap_or(usize::MAX);
    let mut used = 0;
    let mut n = 0;
    for line in sb.lines.iter().skip(skip) {
        used += wrap(line, width).len();
        if used > height {
            break;
        }
        n += 1;
    }
    n.max(1)
}

/// What Enter sends for a typed line: commands as typed; a reply spec or `$SNIPPET`
/// addressed to the selected robot (`@N`); `every S BODY` bound to the selected robot.
/// `all`: Alt+Enter, the line goes to every robot.
fn command_for(line: &str, selected: Option<u64>, all: bool) -> String {
    let targeted = line.starts_with('@') || line.starts_with("all ");
    let command = targeted
        || matches!(line, "list" | "help" | "snippets" | "every")
        || line.starts_with("close ")
        || line.starts_with("every off");
    let to = if all {
        Some("@*".to_string())
    } else {
        selected.map(|id| format!("@{id}"))
    };
    if let Some(rest) = line.strip_prefix("every ").filter(|_| !command) {
        let (secs, body) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
        let body = body.trim_start();
        return match to {
            Some(to) if !(body.starts_with('@') || body.starts_with("all ")) => {
                format!("every {secs} {to} {body}")
            }
            _ => line.to_string(),
        };
    }
    match to {
        Some(to) if !command => format!("{to} {line}"),
        _ => line.to_string(),
    }
}

/// The help pane's text: the keys, the commands, the snippets with their keys, the bounds.
fn help_text(shared: &Shared) -> Vec<String> {
    let mut lines = vec![
        "Keys".to_string(),
        "  F1 or ? (with an empty input)  this help; Esc, F1 or ? closes it, Up/Down/PgUp/PgDn scroll it".into(),
        "  Up / Down          select a robot (the selection follows the newest one until you pick)".into(),
        "  Enter              send the typed line to the selected robot (or run the command)".into(),
        "  Alt+Enter          send the typed line to every connected robot (like @* LINE)".into(),
        format!("  F2 .. F9           send snippet 1 .. {SNIPPET_KEYS} to the selected robot"),
        "  PgUp / PgDn        scroll the traffic back / forward by a page".into(),
        "  Home / End         the oldest kept line / follow the newest again".into(),
        "  F12                mouse on/off: the wheel scrolls the traffic (off at start, so the terminal's selection copies text)".into(),
        "  Esc or Ctrl+C      quit".into(),
        String::new(),
        "Commands (typed, then Enter)".into(),
    ];
    lines.extend(super::help_lines().into_iter().map(|l| format!("  {l}")));
    lines.push(String::new());
    if shared.snippets.is_empty() {
        lines.push(
            "Snippets: none (start with --snippets FILE; one NAME = REPLY-SPEC a line)".into(),
        );
    } else {
        lines.push("Snippets (--snippets)".into());
        for (i, s) in shared.snippets.iter().enumerate() {
            let key = if i < usize::from(SNIPPET_KEYS) {
                format!("F{}", i + 2)
            } else {
                "  ".into()
            };
            lines.push(format!("  {key:<3} ${:<3} {} = {}", i + 1, s.name, s.spec));
        }
    }
    lines.push(String::new());
    lines.push(format!(
        "Scrollback: the newest {} lines and at most {} KiB per robot; older lines are dropped.",
        out::SCREEN_LINES,
        out::SCREEN_BYTES / 1024
    ));
    lines
}

/// A rectangle of `pct` percent of `area`, centred.
fn centred(area: Rect, pct: u16) -> Rect {
    // In u32: a terminal wider than 728 columns would overflow u16 here.
    let part = |n: u16| u16::try_from(u32::from(n) * u32::from(pct.min(100)) / 100).unwrap_or(n);
    let (w, h) = (part(area.width), part(area.height));
    Rect {
        x: area.x + (area.width - w) / 2,
        y: area.y + (area.height - h) / 2,
        width: w,
        height: h,
    }
}

/// The UI until Esc or Ctrl+C, or until the listener is `done`: each turn follows the
/// selection, draws a frame, then handles at most one terminal event (waiting up to
/// 100 ms for it, so the frame follows the traffic).
fn ui_loop(
    terminal: &mut ratatui::DefaultTerminal,
    shared: &Shared,
    cmds: &mpsc::Sender<Result<String, String>>,
    done: &AtomicBool,
) -> Result<(), String> {
    let mut ui = Ui::default();
    while !done.load(Ordering::Relaxed) {
        let rows = rows(shared);
        follow_newest(&mut ui, &rows);
        draw(terminal, &mut ui, shared, &rows)?;
        if !event::poll(Duration::from_millis(100)).map_err(terminal_error)? {
            continue;
        }
        let flow = match event::read().map_err(terminal_error)? {
            Event::Key(key) => on_key(&mut ui, shared, cmds, &rows, key)?,
            Event::Mouse(m) if !ui.help => {
                on_mouse(&mut ui, shared, m.kind);
                ControlFlow::Continue(())
            }
            _ => ControlFlow::Continue(()),
        };
        if flow.is_break() {
            return Ok(());
        }
    }
    Ok(())
}

/// A terminal error as the UI reports it.
fn terminal_error(e: std::io::Error) -> String {
    format!("terminal: {e}")
}

/// Chooses the selected robot from `rows`: a selection that is gone moves to the newest
/// live robot (else the newest row), and so does one not picked by hand once its robot
/// has closed. A new selection follows the end of its traffic.
fn follow_newest(ui: &mut Ui, rows: &[Row]) {
    let selected_live = rows.iter().any(|r| Some(r.id) == ui.selected && r.live);
    if ui.selected.is_none_or(|s| !rows.iter().any(|r| r.id == s)) || (!ui.picked && !selected_live)
    {
        let next = rows
            .iter()
            .rev()
            .find(|r| r.live)
            .or(rows.last())
            .map(|r| r.id);
        select(ui, next);
    }
}

/// The newest general lines (notes, warnings) for the status area: at most [`STATUS_ROWS`].
fn status_lines(shared: &Shared) -> Vec<String> {
    shared
        .out
        .screen
        .as_ref()
        .map(|sc| {
            let sc = sc.lock().unwrap_or_else(|p| p.into_inner());
            let skip = sc.general.len().saturating_sub(STATUS_ROWS);
            sc.general.iter().skip(skip).cloned().collect()
        })
        .unwrap_or_default()
}

/// How many periodic sends (`every`) are running.
fn running_jobs(shared: &Shared) -> usize {
    shared
        .periodic
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .values()
        .filter(|j| !j.task.is_finished())
        .count()
}

/// Draws one frame: the robots, the selected robot's traffic, the input line, the status
/// area and, while open, the help over them. Remembers the traffic pane's size and page
/// in `ui` (scrolling needs them) and clamps the help's scroll to its length.
fn draw(
    terminal: &mut ratatui::DefaultTerminal,
    ui: &mut Ui,
    shared: &Shared,
    rows: &[Row],
) -> Result<(), String> {
    let status = status_lines(shared);
    let help = ui.help.then(|| help_text(shared));
    let jobs = running_jobs(shared);
    terminal
        .draw(|f| {
            let (status_rows, _) =
                bottom_rows(status.iter(), usize::from(f.area().width), STATUS_ROWS);
            let [main, input_area, status_area] = Layout::vertical([
                Constraint::Min(3),
                Constraint::Length(3),
                Constraint::Length(status_rows.len() as u16),
            ])
            .areas(f.area());
            let [list_area, traffic_area] =
                Layout::horizontal([Constraint::Length(36), Constraint::Min(10)]).areas(main);
            draw_robots(f, list_area, rows, ui.selected);
            draw_traffic(f, traffic_area, ui, shared);
            draw_input(f, input_area, ui, jobs);
            let status: Vec<Line> = status_rows.iter().map(|r| Line::raw(r.clone())).collect();
            f.render_widget(Paragraph::new(status), status_area);
            if let Some(help) = &help {
                draw_help(f, ui, help);
            }
        })
        .map_err(terminal_error)?;
    Ok(())
}

/// The robots' list, the `selected` one highlighted.
fn draw_robots(f: &mut Frame, area: Rect, rows: &[Row], selected: Option<u64>) {
    let items: Vec<ListItem> = rows
        .iter()
        .map(|r| ListItem::new(r.label.clone()))
        .collect();
    let list = List::new(items)
        .block(
            Block::default()
                .borders(Borders::ALL)
                .title("robots (Up/Down)"),
        )
        .highlight_style(Style::default().add_modifier(Modifier::REVERSED))
        .highlight_symbol("> ");
    let mut state = ListState::default();
    state.select(rows.iter().position(|r| Some(r.id) == selected));
    f.render_stateful_widget(list, area, &mut state);
}

/// The selected robot's traffic, ending where the view is scrolled to; the title says
/// how many lines are below a scrolled-back view. Sets the pane's size and page in `ui`.
fn draw_traffic(f: &mut Frame, area: Rect, ui: &mut Ui, shared: &Shared) {
    let height = usize::from(area.height.saturating_sub(2));
    let width = usize::from(area.width.saturating_sub(2));
    (ui.height, ui.width) = (height, width);
    let (shown, below) = match (shared.out.screen.as_ref(), ui.selected) {
        (Some(sc), Some(id)) => {
            let sc = sc.lock().unwrap_or_else(|p| p.into_inner());
            match sc.per_conn.get(&id) {
                Some(sb) => {
                    // A view scrolled past the oldest kept line shows it at the top.
                    let end = ui.back.unwrap_or(sb.total).clamp(sb.first(), sb.total);
                    let (shown, whole) = traffic_rows(sb, end, width, height);
                    ui.page = whole.max(1);
                    (shown, sb.total - end)
                }
                None => (Vec::new(), 0),
            }
        }
        _ => (Vec::new(), 0),
    };
    let title = match ui.selected {
        Some(id) if ui.back.is_some() => {
            format!("#{id} traffic, scrolled back: {below} new lines below (End follows)")
        }
        Some(id) => format!("#{id} traffic (PgUp scrolls back)"),
        None => "no robot yet".to_string(),
    };
    let shown: Vec<Line> = shown.into_iter().map(Line::raw).collect();
    f.render_widget(
        Paragraph::new(shown).block(Block::default().borders(Borders::ALL).title(title)),
        area,
    );
}

/// The input line, its title naming where Enter sends and how many periodic sends
/// (`jobs`) run.
fn draw_input(f: &mut Frame, area: Rect, ui: &Ui, jobs: usize) {
    let target = ui
        .selected
        .map(|id| format!("#{id}"))
        .unwrap_or_else(|| "-".into());
    let jobs = if jobs > 0 {
        format!(" | {jobs} periodic (every)")
    } else {
        String::new()
    };
    // A line longer than the box shows its end, where the typing is.
    let typed = format!("> {}", ui.input);
    let inner = usize::from(area.width.saturating_sub(2));
    let typed = tail(&typed, inner);
    f.render_widget(
        Paragraph::new(typed).block(Block::default().borders(Borders::ALL).title(format!(
            "send to {target}: floats 1 2 3 | line OK | hex 02 41 03 | $snippet{jobs}  (F1 help, Esc quits)"
        ))),
        area,
    );
}

/// The help pane over the middle of the frame, scrolled to `ui.help_scroll` (clamped
/// there to its last row).
fn draw_help(f: &mut Frame, ui: &mut Ui, help: &[String]) {
    let area = centred(f.area(), 90);
    // Scrolled no further than its last row.
    let inner = usize::from(area.width.saturating_sub(2));
    // Wrapped here, as the traffic is, so the row count is exact.
    let rows: Vec<Line> = help
        .iter()
        .flat_map(|l| wrap(l, inner))
        .map(Line::raw)
        .collect();
    let last = rows
        .len()
        .saturating_sub(usize::from(area.height.saturating_sub(2)));
    ui.help_scroll = ui.help_scroll.min(u16::try_from(last).unwrap_or(u16::MAX));
    f.render_widget(Clear, area);
    f.render_widget(
        Paragraph::new(rows).scroll((ui.help_scroll, 0)).block(
            Block::default()
                .borders(Borders::ALL)
                .title("help (Esc closes, Up/Down scroll)"),
        ),
        area,
    );
}

/// A mouse event (mouse capture on, help closed): the wheel scrolls the traffic by
/// [`WHEEL_LINES`].
fn on_mouse(ui: &mut Ui, shared: &Shared, kind: MouseEventKind) {
    match kind {
        MouseEventKind::ScrollUp => scroll(ui, shared, Move::Up(WHEEL_LINES)),
        MouseEventKind::ScrollDown => scroll(ui, shared, Move::Down(WHEEL_LINES)),
        _ => {}
    }
}

/// One key event: Ctrl+C quits; with the help open, the help's keys; else Esc quits and
/// the other keys select, scroll, send snippets, toggle the mouse or edit and send the
/// input line. Only presses count (not releases or repeats reported as such).
fn on_key(
    ui: &mut Ui,
    shared: &Shared,
    cmds: &mpsc::Sender<Result<String, String>>,
    rows: &[Row],
    key: KeyEvent,
) -> Result<ControlFlow<()>, String> {
    if key.kind != KeyEventKind::Press {
        return Ok(ControlFlow::Continue(()));
    }
    if key.code == KeyCode::Char('c') && key.modifiers.contains(KeyModifiers::CONTROL) {
        return Ok(ControlFlow::Break(()));
    }
    if ui.help {
        help_key(ui, key);
        return Ok(ControlFlow::Continue(()));
    }
    match key.code {
        KeyCode::Esc => return Ok(ControlFlow::Break(())),
        KeyCode::F(1) => open_help(ui),
        KeyCode::Char('?') if ui.input.is_empty() => open_help(ui),
        KeyCode::F(n) if (2..2 + SNIPPET_KEYS).contains(&n) => match ui.selected {
            Some(id) => send(cmds, format!("@{id} ${}", n - 1)),
            None => send(cmds, format!("${}", n - 1)),
        },
        KeyCode::Up => pick(ui, rows, Step::Up),
        KeyCode::Down => pick(ui, rows, Step::Down),
        KeyCode::PageUp => {
            let page = ui.page.saturating_sub(1);
            scroll(ui, shared, Move::Up(page));
        }
        KeyCode::PageDown => {
            let page = ui.page.saturating_sub(1);
            scroll(ui, shared, Move::Down(page));
        }
        KeyCode::Home => scroll(ui, shared, Move::Home),
        KeyCode::End => scroll(ui, shared, Move::End),
        KeyCode::F(12) => toggle_mouse(ui)?,
        KeyCode::Enter => enter(ui, cmds, key.modifiers.contains(KeyModifiers::ALT)),
        KeyCode::Backspace => {
            ui.input.pop();
        }
        KeyCode::Char(c) => ui.input.push(c),
        _ => {}
    }
    Ok(ControlFlow::Continue(()))
}

/// Queues `line` for the listener's command loop, as if typed on stdin (dropped once
/// the listener has stopped reading commands).
fn send(cmds: &mpsc::Sender<Result<String, String>>, line: String) {
    let _ = cmds.blocking_send(Ok(line));
}

/// Enter: takes the typed line; `help` opens the help, any other non-blank line is sent
/// as [`command_for`] addresses it (`all`: Alt+Enter, to every robot).
fn enter(ui: &mut Ui, cmds: &mpsc::Sender<Result<String, String>>, all: bool) {
    let line = std::mem::take(&mut ui.input);
    let line = line.trim();
    if line == "help" {
        open_help(ui);
    } else if !line.is_empty() {
        send(cmds, command_for(line, ui.selected, all));
    }
}

/// F12: turns mouse capture on or off.
fn toggle_mouse(ui: &mut Ui) -> Result<(), String> {
    ui.mouse = !ui.mouse;
    let mut out = std::io::stdout();
    if ui.mouse {
        ratatui::crossterm::execute!(out, EnableMouseCapture)
    } else {
        ratatui::crossterm::execute!(out, DisableMouseCapture)
    }
    .map_err(terminal_error)
}

/// A step through the robots' list.
#[derive(Clone, Copy)]
enum Step {
    Up,
    Down,
}

/// Up/Down: selects the row above or below the selected one (staying at either end), and
/// stops the selection following the newest robot.
fn pick(ui: &mut Ui, rows: &[Row], step: Step) {
    ui.picked = true;
    let Some(i) = rows.iter().position(|r| Some(r.id) == ui.selected) else {
        return;
    };
    let next = match step {
        Step::Up => rows.get(i.saturating_sub(1)),
        Step::Down => rows.get((i + 1).min(rows.len().saturating_sub(1))),
    };
    select(ui, next.map(|r| r.id));
}

/// Opens the help at its top.
fn open_help(ui: &mut Ui) {
    ui.help = true;
    ui.help_scroll = 0;
}

/// A key while the help is open: Esc, F1, ? or q closes it, Up/Down/PgUp/PgDn scroll it.
fn help_key(ui: &mut Ui, key: KeyEvent) {
    match key.code {
        KeyCode::Esc | KeyCode::F(1) | KeyCode::Char('?' | 'q') => ui.help = false,
        KeyCode::Up => ui.help_scroll = ui.help_scroll.saturating_sub(1),
        // Clamped to the help's length when drawn.
        KeyCode::Down => ui.help_scroll = ui.help_scroll.saturating_add(1),
        KeyCode::PageUp => ui.help_scroll = ui.help_scroll.saturating_sub(10),
        KeyCode::PageDown => ui.help_scroll = ui.help_scroll.saturating_add(10),
        _ => {}
    }
}

/// Selects robot `id`; a different robot's traffic is shown from its end.
fn select(ui: &mut Ui, id: Option<u64>) {
    if id != ui.selected {
        ui.back = None;
    }
    ui.selected = id;
}

/// A move of the traffic view.
#[derive(Clone, Copy)]
enum Move {
    /// Lines back (PgUp: the whole lines the pane showed, less one kept for context; the
    /// wheel: [`WHEEL_LINES`]).
    Up(u64),
    Down(u64),
    /// The oldest kept line at the top.
    Home,
    /// Follow the newest again.
    End,
}

/// Moves the traffic view; reaching the end (End, or PgDn/wheel past it) follows again.
fn scroll(ui: &mut Ui, shared: &Shared, how: Move) {
    let (Some(sc), Some(id)) = (shared.out.screen.as_ref(), ui.selected) else {
        return;
    };
    let sc = sc.lock().unwrap_or_else(|p| p.into_inner());
    let Some(sb) = sc.per_conn.get(&id) else {
        return;
    };
    let (first, total) = (sb.first(), sb.total);
    let end = ui.back.unwrap_or(total).clamp(first, total);
    // The view never ends before the pane is full of the oldest lines: Home shows the
    // oldest line at the top.
    let top = first
        .saturating_add(fit_from(sb, first, ui.width, ui.height))
        .min(total);
    let next = match how {
        Move::Up(n) => end.saturating_sub(n.max(1)).max(top),
        Move::Down(n) => end.saturating_add(n.max(1)),
        Move::Home => top,
        Move::End => total,
    };
    ui.back = (next < total).then_some(next);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_help_pane_fits_any_terminal() {
        let huge = Rect::new(0, 0, u16::MAX, u16::MAX);
        let r = centred(huge, 90);
        assert_eq!((r.width, r.height), (58981, 58981));
        let tiny = centred(Rect::new(0, 0, 1, 1), 90);
        assert_eq!((tiny.width, tiny.height), (0, 0));
    }

    #[test]
    fn lines_wrap_by_display_width() {
        assert_eq!(wrap("", 4), [""]);
        assert_eq!(wrap("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        // Two columns each: three fit in six.
        assert_eq!(wrap("日本語です", 6), ["日本語", "です"]);
        assert_eq!(wrap("ab", 0), ["a", "b"]);
        assert_eq!(tail("> hex 02 41 03", 6), " 41 03");
        assert_eq!(tail("> 日本語", 5), "本語");
        assert_eq!(tail("> ab", 10), "> ab");
        assert_eq!(tail("abc", 0), "");
    }

    #[test]
    fn enter_addresses_the_selected_robot_and_alt_enter_every_robot() {
        assert_eq!(command_for("line OK", Some(3), false), "@3 line OK");
        assert_eq!(command_for("$pose", Some(3), false), "@3 $pose");
        assert_eq!(command_for("line OK", Some(3), true), "@* line OK");
        assert_eq!(command_for("line OK", None, false), "line OK");
        assert_eq!(command_for("@1 line OK", Some(3), false), "@1 line OK");
        assert_eq!(command_for("all line OK", Some(3), false), "all line OK");
        for cmd in [
            "list",
            "help",
            "snippets",
            "every",
            "every off",
            "every off 2",
            "close 1",
        ] {
            assert_eq!(command_for(cmd, Some(3), false), cmd);
        }
        assert_eq!(
            command_for("every 0.5 $pose", Some(3), false),
            "every 0.5 @3 $pose"
        );
        assert_eq!(
            command_for("every 0.5 $pose", Some(3), true),
            "every 0.5 @* $pose"
        );
        assert_eq!(
            command_for("every 0.5 @1 $pose", Some(3), false),
            "every 0.5 @1 $pose"
        );
    }

    fn scrollback(n: usize) -> out::Scrollback {
        let mut sb = out::Scrollback::default();
        for i in 0..n {
            sb.push(format!("line {i}"));
        }
        sb
    }

    #[test]
    fn the_traffic_pane_shows_the_lines_before_its_end() {
        let sb = scrollback(10);
        let (rows, whole) = traffic_rows(&sb, 10, 20, 3);
        assert_eq!(rows, ["line 7", "line 8", "line 9"]);
        assert_eq!(whole, 3);
        let (rows, _) = traffic_rows(&sb, 5, 20, 3);
        assert_eq!(rows, ["line 2", "line 3", "line 4"]);
        // Past either end: clamped.
        assert_eq!(traffic_rows(&sb, 99, 20, 1).0, ["line 9"]);
        assert!(traffic_rows(&sb, 0, 20, 3).0.is_empty());
        // A wrapped top line shows its last rows, and is not counted whole.
        assert_eq!(fit_from(&sb, 0, 20, 3), 3);
        assert_eq!(fit_from(&sb, 0, 3, 5), 2, "two lines of two rows each");
        assert_eq!(fit_from(&sb, 9, 20, 3), 1);
        assert_eq!(
            fit_from(&sb, 0, 1, 1),
            1,
            "a line taller than the pane still counts"
        );
        let (rows, whole) = traffic_rows(&sb, 10, 3, 5);
        assert_eq!(rows, ["e 7", "lin", "e 8", "lin", "e 9"]);
        assert_eq!(whole, 2);
    }
}
