//! Text into HTML.

/// `text` safe in HTML text and in double- or single-quoted attribute values: `&`, `<`, `>`,
/// `"` and `'` become character references; everything else (µ, σ, Δ) stays as it is, the page
/// being UTF-8.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// The unit as people write it: `um` → `µm`, `urad` → `µrad`, `deg` → `°`; others unchanged.
pub(crate) fn display_unit(unit: &str) -> &str {
    match unit {
        "um" => "µm",
        "urad" => "µrad",
        "deg" => "°",
        other => other,
    }
}

/// `value ± u95` rounded to the interval's second significant digit.
pub(crate) fn with_interval(value: f64, u95: f64) -> (String, String) {
    let decimals = if u95.is_finite() && u95 > 0.0 {
        (1 - u95.log10().floor() as i32).clamp(0, 9) as usize
    } else {
        4
    };
    (
        format!("{value:.decimals$}").replace('-', "−"),
        format!("{u95:.decimals$}"),
    )
}

/// A number with `decimals` places and a real minus sign.
pub(crate) fn num(value: f64, decimals: usize) -> String {
    format!("{value:.decimals$}").replace('-', "−")
}
