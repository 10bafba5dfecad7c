//! Number text shared by the text formats: the conservative plain-decimal float form,
//! the float and int token grammars. Internal; each format exposes what it needs.

use crate::ErrorKind;

/// The longest plain-decimal text of a finite f64: `-0.` + 323 zeros + `5` for the
/// smallest subnormal is 327 bytes; `-` + 309 digits for the largest is 310.
pub const MAX_PLAIN_F64_LEN: usize = 327;

/// Writes the shortest decimal text that parses back to exactly `v`, in plain notation
/// (no exponent), into `out` (at least [`MAX_PLAIN_F64_LEN`] bytes), returning the
/// length. `v` must be finite.
///
/// ryu finds the shortest round-trip digits (and is several times faster than
/// `core::fmt`); we only re-lay its `d.ddde±x` output as plain decimal. The decimal value
/// is unchanged by that, so the text still parses back bit-exactly.
pub fn write_plain_f64(v: f64, out: &mut [u8]) -> usize {
    debug_assert!(v.is_finite());
    if let Some(n) = write_short_decimal(v, out) {
        return n;
    }
    let mut ryu_buf = ryu::Buffer::new();
    let text = ryu_buf.format_finite(v).as_bytes();

    let mut i = 0;
    let mut len = 0;
    if text.first() == Some(&b'-') {
        out[0] = b'-';
        len = 1;
        i = 1;
    }
    // Collect the significant digits; `point` = digits before the decimal point.
    let mut digits = [0u8; 17];
    let mut n = 0usize;
    let mut point: i32 = 0;
    let mut seen_point = false;
    let mut exp: i32 = 0;
    while i < text.len() {
        let c = text[i];
        match c {
            b'0'..=b'9' => {
                if n == 0 && c == b'0' {
                    // A leading zero: shifts the point left if after it.
                    if seen_point {
                        point -= 1;
                    }
                } else if n < digits.len() {
                    digits[n] = c;
                    n += 1;
                    if !seen_point {
                        point += 1;
                    }
                }
            }
            b'.' => seen_point = true,
            b'e' | b'E' => {
                let mut neg = false;
                let mut j = i + 1;
                if text.get(j) == Some(&b'-') {
                    neg = true;
                    j += 1;
                }
                let mut e: i32 = 0;
                while j < text.len() {
                    e = e * 10 + i32::from(text[j] - b'0');
                    j += 1;
                }
                exp = if neg { -e } else { e };
                break;
            }
            _ => {}
        }
        i += 1;
    }
    while n > 0 && digits[n - 1] == b'0' {
        n -= 1;
    }
    if n == 0 {
        out[len] = b'0';
        return len + 1;
    }
    let point = point + exp;
    let digits = &digits[..n];
    if point <= 0 {
        let zeros = (-point) as usize;
        out[len] = b'0';
        out[len + 1] = b'.';
        len += 2;
        out[len..len + zeros].fill(b'0');
        len += zeros;
        out[len..len + n].copy_from_slice(digits);
        len + n
    } else if point as usize >= n {
        let zeros = point as usize - n;
        out[len..len + n].copy_from_slice(digits);
        len += n;
        out[len..len + zeros].fill(b'0');
        len + zeros
    } else {
        let p = point as usize;
        out[len..len + p].copy_from_slice(&digits[..p]);
        len += p;
        out[len] = b'.';
        len += 1;
        out[len..len + n - p].copy_from_slice(&digits[p..]);
        len + n - p
    }
}

/// Fast path for the values robots and vision systems actually exchange: at most 9
/// decimals and below 1e6 (or integers below 2^53).
///
/// Why it is exact: with `a = |v|` and `m` the integer nearest `a * 1e9`, below 1e15, IEEE division
/// gives the double nearest to the decimal `m / 10^9`. If that is `a`, the decimal (15
/// significant digits at most) reads back as `v`. Two distinct decimals of at most 15
/// significant digits never round to the same double (their relative spacing, 1e-15 at
/// least, exceeds a double's 2^-52), so this decimal is the only one of that length: exactly
/// the shortest round-trip text ryu would find, minus trailing zeros. Otherwise `None`,
/// and the general path runs. Saves the shortest-digits search for ~all pose values.
#[inline]
fn write_short_decimal(v: f64, out: &mut [u8]) -> Option<usize> {
    let a = v.abs();
    // (`f64::round`/`fract` need std; `as u64` truncation is in core and exact here.)
    let (m, frac_digits) = if a < 1e6 {
        // Below 1e15: i64 conversions are single instructions (u64's are not).
        let m = (a * 1e9 + 0.5) as i64;
        if m as f64 / 1e9 != a {
            return None;
        }
        (m as u64, 9usize)
    } else if a < 9_007_199_254_740_992.0 && (a as u64) as f64 == a {
        (a as u64, 0)
    } else {
        return None;
    };
    // Digits two at a time from a table, right to left.
    const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
                                2021222324252627282930313233343536373839\
                                4041424344454647484950515253545556575859\
                                6061626364656667686970717273747576777879\
                                8081828384858687888990919293949596979899";
    let mut digits = [b'0'; 20];
    let mut pos = 20;
    let mut x = m;
    while x >= 100 {
        let pair = (x % 100) as usize * 2;
        x /= 100;
        pos -= 2;
        digits[pos..pos + 2].copy_from_slice(&PAIRS[pair..pair + 2]);
    }
    if x >= 10 {
        let pair = x as usize * 2;
        pos -= 2;
        digits[pos..pos + 2].copy_from_slice(&PAIRS[pair..pair + 2]);
    } else {
        pos -= 1;
        digits[pos] = b'0' + x as u8;
    }
    // At least one integer digit: pad with zeros to frac_digits + 1 digits.
    let n = (20 - pos).max(frac_digits + 1);
    let digits = &digits[20 - n..];
    let int_len = n - frac_digits;
    let mut len = 0;
    if v.is_sign_negative() {
        out[0] = b'-';
        len = 1;
    }
    out[len..len + int_len].copy_from_slice(&digits[..int_len]);
    len += int_len;
    let mut frac = &digits[int_len..];
    while let [rest @ .., b'0'] = frac {
        frac = rest;
    }
    if !frac.is_empty() {
        out[len] = b'.';
        out[len + 1..len + 1 + frac.len()].copy_from_slice(frac);
        len += 1 + frac.len();
    }
    Some(len)
}

/// Exact powers of ten, 10^0..=10^22: every one is a double.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

const POW10_U64: [u64; 9] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
];

/// The leading ASCII digits among the first 8 bytes of `bytes` (which must hold 8) as
/// (value, how many), computed on one little-endian `u64` (SWAR), or `None` if fewer than 8
/// bytes are there.
///
/// Why it is exact: a byte `c` is a digit iff `c - 0x30` does not borrow and `c + 0x46`
/// does not reach 0x80; carries and borrows only travel towards later bytes, so the first
/// flagged byte is the first non-digit. The `n` digits are moved to the top of the word
/// (zeros below act as leading zeros) and combined pairwise (fast-float's
/// `parse_eight_digits_unrolled`). Checked against the byte loop by a property test.
#[inline]
fn swar_digits(bytes: &[u8]) -> Option<(u64, usize)> {
    let chunk: [u8; 8] = bytes.get(..8)?.try_into().ok()?;
    let x = u64::from_le_bytes(chunk);
    let flags = (x.wrapping_add(0x4646_4646_4646_4646) | x.wrapping_sub(0x3030_3030_3030_3030))
        & 0x8080_8080_8080_8080;
    let n = if flags == 0 {
        8
    } else {
        (flags.trailing_zeros() / 8) as usize
    };
    if n == 0 {
        return Some((0, 0));
    }
    let mut v = x.wrapping_sub(0x3030_3030_3030_3030) << ((8 - n) * 8);
    v = v.wrapping_mul(10).wrapping_add(v >> 8);
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 0x000F_4240_0000_0064;
    const MUL2: u64 = 0x0000_2710_0000_0001;
    v = ((v & MASK)
        .wrapping_mul(MUL1)
        .wrapping_add(((v >> 16) & MASK).wrapping_mul(MUL2)))
        >> 32;
    Some((v, n))
}

/// Parses the plain decimal at the start of `bytes` (`[+-]? digits ('.' digits)?`) when
/// Clinger's fast path applies, returning the value and the bytes used; `None` sends the
/// caller to the general parser (exponents, more than 15 digits, no digit at all).
///
/// Why it is exact: the digits form an integer `m` below 10^15 < 2^53 and the number is
/// `m / 10^k` with `k` <= 22, so both operands are exact doubles and IEEE division
/// rounds the true quotient correctly: the same double any correct parser returns. For
/// the 6-decimal values of poses this skips the general algorithm entirely.
#[inline]
pub fn parse_short_decimal(bytes: &[u8]) -> Option<(f64, usize)> {
    let (neg, body) = match bytes {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, bytes),
    };
    let sign_len = bytes.len() - body.len();
    // Iterating slices (not indexing) lets the compiler drop the bounds checks.
    let int_len = body.iter().take_while(|c| c.is_ascii_digit()).count();
    let mut m: u64 = 0;
    for &c in &body[..int_len] {
        m = m.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
    }
    let mut used = int_len;
    let mut frac = 0;
    if let [b'.', after @ ..] = &body[int_len..] {
        match swar_digits(after) {
            // Up to 8 fraction digits in one step (the 6-decimal case of every pose).
            Some((value, n)) if n < 8 => {
                frac = n;
                m = m.wrapping_mul(POW10_U64[n]).wrapping_add(value);
            }
            _ => {
                frac = after.iter().take_while(|c| c.is_ascii_digit()).count();
                for &c in &after[..frac] {
                    m = m.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
                }
            }
        }
        used += 1 + frac;
    }
    let digits = int_len + frac;
    // No digit, too many for the fast path (m might not be exact), or an exponent next.
    if digits == 0 || digits > 15 || matches!(body.get(used), Some(b'e' | b'E')) {
        return None;
    }
    // `m` < 10^15 fits an i64, whose conversion is one instruction (u64's is four).
    let v = m as i64 as f64 / POW10[frac];
    Some((if neg { -v } else { v }, sign_len + used))
}

/// The crate's one float grammar, `[+-]? (d+ ('.' d*)? | '.' d+) ([eE] [+-]? d+)?` (the
/// exponent only when `allow_exponent`), read from the start of `bytes`: the value and the
/// bytes it used. `Err(i)`: `bytes[i]` is where it stops being a number (0 when it does
/// not start as one). Shared by the float tuple reader and the `to_str` parser.
///
/// Fast path first ([`parse_short_decimal`]: Clinger, exact, SWAR fraction digits), else
/// fast-float, which accepts exactly this grammar plus `inf`/`nan`, excluded here by the
/// first-byte check; the exponent policy is checked on the (short) span it consumed.
#[inline]
pub fn parse_float_prefix(bytes: &[u8], allow_exponent: bool) -> Result<(f64, usize), usize> {
    let first_digit = match bytes {
        [b'+' | b'-', rest @ ..] => rest.first(),
        _ => bytes.first(),
    };
    if !matches!(first_digit, Some(b'0'..=b'9' | b'.')) {
        return Err(0);
    }
    // Plain decimals of up to 15 digits (every pose value) take the exact fast path;
    // anything else goes to fast-float.
    let (v, len) = match parse_short_decimal(bytes) {
        Some(found) => found,
        None => fast_float2::parse_partial::<f64, _>(bytes).map_err(|_| 0usize)?,
    };
    if !allow_exponent {
        if let Some(e) = bytes[..len].iter().position(|&b| b | 0x20 == b'e') {
            return Err(e);
        }
    }
    Ok((v, len))
}

/// `token` as one number of the float grammar ([`parse_float_prefix`]), nothing after it.
/// On failure returns the index of the first offending byte within `token`.
#[inline]
pub fn parse_float_token(token: &[u8], allow_exponent: bool) -> Result<f64, usize> {
    match parse_float_prefix(token, allow_exponent)? {
        (v, len) if len == token.len() => Ok(v),
        (_, len) => Err(len),
    }
}

/// Parses a decimal int32: optional sign, one or more digits (leading zeros allowed).
pub fn parse_i32(token: &[u8]) -> Result<i32, (ErrorKind, usize)> {
    let (neg, digits_at) = match token.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    if token.len() == digits_at {
        return Err((ErrorKind::InvalidNumber, token.len().saturating_sub(1)));
    }
    // Accumulate negatively so that i32::MIN parses.
    let mut acc: i32 = 0;
    for (i, &c) in token.iter().enumerate().skip(digits_at) {
        if !c.is_ascii_digit() {
            return Err((ErrorKind::InvalidNumber, i));
        }
        acc = acc
            .checked_mul(10)
            .and_then(|a| a.checked_sub(i32::from(c - b'0')))
            .ok_or((ErrorKind::IntegerOutOfRange, 0))?;
    }
    if neg {
        Ok(acc)
    } else {
        acc.checked_neg().ok_or((ErrorKind::IntegerOutOfRange, 0))
    }
}

/// Writes the decimal text of `v` into `out`, returning the length (at most 11).
pub fn write_i32(v: i32, out: &mut [u8; 11]) -> usize {
    let mut tmp = [0u8; 11];
    let mut n = 0;
    let mut u = v.unsigned_abs();
    loop {
        tmp[n] = b'0' + (u % 10) as u8;
        n += 1;
        u /= 10;
        if u == 0 {
            break;
        }
    }
    let mut len = 0;
    if v < 0 {
        out[0] = b'-';
        len = 1;
    }
    for k in (0..n).rev() {
        out[len] = tmp[k];
        len += 1;
    }
    len
}

/// ASCII whitespace the text formats allow around numbers: space, tab, CR, LF.
#[inline]
pub fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\n')
}

/// Splits off spaces at both ends, returning the offset of the trimmed start.
#[inline]
pub fn trim(bytes: &[u8]) -> (usize, &[u8]) {
    let mut s = 0;
    let mut e = bytes.len();
    while s < e && is_space(bytes[s]) {
        s += 1;
    }
    while e > s && is_space(bytes[e - 1]) {
        e -= 1;
    }
    (s, &bytes[s..e])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plain(v: f64) -> alloc::string::String {
        let mut out = [0u8; MAX_PLAIN_F64_LEN];
        let n = write_plain_f64(v, &mut out);
        alloc::string::String::from_utf8(out[..n].to_vec()).unwrap()
    }

    #[test]
    fn plain_forms() {
        assert_eq!(plain(1.414), "1.414");
        assert_eq!(plain(0.0), "0");
        assert_eq!(plain(-0.0), "-0");
        assert_eq!(plain(3.0), "3");
        assert_eq!(plain(-0.15), "-0.15");
        assert_eq!(plain(1e16), "10000000000000000");
        assert_eq!(plain(1.5e-7), "0.00000015");
        assert_eq!(plain(123456.789), "123456.789");
        assert_eq!(plain(f64::MAX).len(), 309);
        assert_eq!(
            plain(-f64::MIN_POSITIVE * f64::EPSILON).len(),
            MAX_PLAIN_F64_LEN
        );
        assert_eq!(plain(-0.123456), "-0.123456");
        assert_eq!(plain(999999.999999999), "999999.999999999");
        assert_eq!(plain(0.000000001), "0.000000001");
        assert_eq!(plain(0.1 + 0.2), "0.30000000000000004");
        assert_eq!(plain(9007199254740991.0), "9007199254740991");
        assert_eq!(plain(1e15 + 0.5), "1000000000000000.5");
    }

    /// The fast path agrees with the general one wherever it applies: it reads back
    /// bit-exactly and is the shortest text (std's `Display` is shortest round-trip too).
    #[test]
    fn fast_path_matches_shortest() {
        let mut x: u64 = 1;
        let mut taken = 0;
        for i in 0..200_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = match i % 4 {
                0 => f64::from_bits(x),
                1 => ((x % 2_000_000_000_000) as f64 - 1e12) / 1e6,
                2 => (x % 100_000_000) as f64 / 1e4 * if x & 1 == 0 { 1.0 } else { -1.0 },
                _ => (x % 1_000_000_000) as f64 * 1e-9,
            };
            if !v.is_finite() {
                continue;
            }
            let mut a = [0u8; MAX_PLAIN_F64_LEN];
            let Some(n) = write_short_decimal(v, &mut a) else {
                continue;
            };
            taken += 1;
            let text = core::str::from_utf8(&a[..n]).unwrap();
            assert_eq!(
                text.parse::<f64>().unwrap().to_bits(),
                v.to_bits(),
                "{text}"
            );
            assert_eq!(text, alloc::format!("{v}"), "shortest, as std's Display");
        }
        assert!(taken > 100_000, "the fast path is the common path: {taken}");
    }

    #[test]
    fn i32_text() {
        for v in [0, 1, -1, 10, -3, i32::MAX, i32::MIN, 2200] {
            let mut out = [0u8; 11];
            let n = write_i32(v, &mut out);
            assert_eq!(parse_i32(&out[..n]), Ok(v));
            assert_eq!(
                core::str::from_utf8(&out[..n]).unwrap(),
                alloc::format!("{v}")
            );
        }
        assert_eq!(parse_i32(b"077"), Ok(77));
        assert_eq!(
            parse_i32(b"2147483648").unwrap_err().0,
            ErrorKind::IntegerOutOfRange
        );
        assert_eq!(parse_i32(b"-2147483648"), Ok(i32::MIN));
        assert_eq!(parse_i32(b"12a"), Err((ErrorKind::InvalidNumber, 2)));
        assert!(parse_i32(b"-").is_err());
        assert!(parse_i32(b"").is_err());
    }

    #[test]
    fn short_decimal_agrees_with_std() {
        let mut x: u64 = 7;
        for i in 0..200_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let text = match i % 3 {
                0 => alloc::format!("{}", ((x % 2_000_000_000) as f64 - 1e9) / 1e6),
                1 => alloc::format!("{}.{:0w$}", x % 1000, x % 1_000_000, w = (i % 10) as usize),
                _ => alloc::format!("-{}", x % 1_000_000_000_000_000),
            };
            if let Some((v, n)) = parse_short_decimal(text.as_bytes()) {
                assert_eq!(n, text.len(), "{text}");
                assert_eq!(
                    v.to_bits(),
                    text.parse::<f64>().unwrap().to_bits(),
                    "{text}"
                );
            }
        }
        assert_eq!(parse_short_decimal(b"-0"), Some((-0.0, 2)));
        assert_eq!(parse_short_decimal(b"1e3"), None);
        assert_eq!(parse_short_decimal(b"."), None);
        assert_eq!(parse_short_decimal(b"-"), None);
        assert_eq!(parse_short_decimal(b"1234567890123456"), None);
        assert_eq!(parse_short_decimal(b".5,"), Some((0.5, 2)));
        assert_eq!(parse_short_decimal(b"5.)"), Some((5.0, 2)));
    }

    #[test]
    fn swar_digits_agree_with_the_byte_loop() {
        let mut x: u64 = 3;
        for i in 0..300_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let mut b = x.to_le_bytes();
            // Mostly digits, sometimes any byte, at any position.
            for (k, c) in b.iter_mut().enumerate() {
                if (i >> k) & 7 != 0 {
                    *c = b'0' + *c % 10;
                }
            }
            let n = b.iter().take_while(|c| c.is_ascii_digit()).count();
            let want = b[..n]
                .iter()
                .fold(0u64, |m, &c| m * 10 + u64::from(c - b'0'));
            assert_eq!(swar_digits(&b), Some((want, n)), "{b:?}");
        }
        for c in 0..=255u8 {
            let b = [c, b'1', b'2', b'3', b'4', b'5', b'6', b'7'];
            let n = usize::from(c.is_ascii_digit()) * 8;
            let want = if n == 8 {
                u64::from(c - b'0') * 10_000_000 + 1234567
            } else {
                0
            };
            assert_eq!(swar_digits(&b), Some((want, n)), "byte {c}");
        }
        assert_eq!(swar_digits(b"1234567"), None);
    }

    #[test]
    fn float_grammar() {
        assert_eq!(parse_float_token(b"1.414", true), Ok(1.414));
        assert_eq!(parse_float_token(b"-3", true), Ok(-3.0));
        assert_eq!(parse_float_token(b".5", true), Ok(0.5));
        assert_eq!(parse_float_token(b"5.", true), Ok(5.0));
        assert_eq!(parse_float_token(b"1e3", true), Ok(1000.0));
        assert_eq!(parse_float_token(b"1e3", false), Err(1));
        assert_eq!(parse_float_token(b"1e", true), Err(1));
        assert!(parse_float_token(b"nan", true).is_err());
        assert!(parse_float_token(b"inf", true).is_err());
        assert!(parse_float_token(b"-", true).is_err());
        assert!(parse_float_token(b".", true).is_err());
        assert_eq!(parse_float_token(b"1.2.3", true), Err(3));
    }
}
