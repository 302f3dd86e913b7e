//! The fast runway pipeline on bit-packed rows.
//!
//! After the threshold every pixel is one bit (1 = white, grey > threshold), 64 pixels per
//! `u64` word, bit `j` of word `i` of a row being pixel `64·i + j`. The steps are:
//!
//! 1. **Grey + threshold, fused** (`threshold_row`): one pass over the RGB bytes; the grey
//!    level is never materialised, the test `gray > t` is done on the fixed-point sum
//!    (see `color::gray_sum_above`).
//! 2. **Dilation** by a (2r+1)×(2r+1) square, r = the number of 3×3 iterations. Seven 3×3
//!    dilations are one 15×15 dilation: with OpenCV's default border for dilation
//!    (`BORDER_CONSTANT` with `morphologyDefaultBorderValue()`, which never wins a maximum)
//!    the outside of the image contributes nothing, and the set of pixels reachable in r
//!    king's moves without leaving a rectangle is exactly the pixels within Chebyshev
//!    distance r in that rectangle. (OpenCV itself does the same rewrite: `cv::dilate`
//!    with a full rectangular kernel and `iterations > 1` builds one kernel of size
//!    `ksize + (iterations−1)·(ksize−1)`, `modules/imgproc/src/morph.dispatch.cpp`.)
//!    The square is separable: a horizontal then a vertical 1-D maximum, and for bits a
//!    maximum is an OR. Each 1-D window [p−r, p+r] is the OR of a forward window [p, p+r]
//!    and a backward window [p−r, p], each built by doubling (`x |= x ≫ 1; x |= x ≫ 2;
//!    x |= x ≫ 4` covers 8 = r+1 pixels for r = 7), so the work is O(log r) word
//!    operations per 64 pixels, independent of the window size — the bit-parallel form of
//!    the van Herk / Gil-Werman idea. Bits outside the image are 0 (never white), which is
//!    the border rule above.
//! 3. **Counting**: black pixels per region = region size − popcount of the white bits,
//!    with masks for the partial words at the region's left and right edges.
//!
//! [`crate::vision::reference`] is the obviously-correct version (a grey image, a 0/255
//! image, seven 3×3 dilations, counting loops); the property tests check both agree on
//! random images of any size, including sizes below 15 pixels and not a multiple of 64.

use super::color;
use super::regions::{Region, RegionCounts, RegionGrid};
use image::{GrayImage, RgbImage};

/// A binary image, one bit per pixel, rows padded to whole `u64` words with zero bits.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BitImage {
    width: u32,
    height: u32,
    words_per_row: usize,
    words: Vec<u64>,
}

impl BitImage {
    /// An all-zero (all black) image of `width` × `height` pixels.
    pub fn new(width: u32, height: u32) -> BitImage {
        let words_per_row = (width as usize).div_ceil(64);
        BitImage {
            width,
            height,
            words_per_row,
            words: vec![0; words_per_row * height as usize],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The words of row `y` (bit `j` of word `i` is pixel `64·i + j`).
    #[inline(always)]
    pub fn row(&self, y: u32) -> &[u64] {
        let s = y as usize * self.words_per_row;
        &self.words[s..s + self.words_per_row]
    }

    fn row_mut(&mut self, y: u32) -> &mut [u64] {
        let s = y as usize * self.words_per_row;
        &mut self.words[s..s + self.words_per_row]
    }

    /// The pixel at (`x`, `y`): `true` = white (1). Out-of-range pixels are `false`.
    pub fn get(&self, x: u32, y: u32) -> bool {
        if x >= self.width || y >= self.height {
            return false;
        }
        (self.row(y)[(x / 64) as usize] >> (x % 64)) & 1 == 1
    }

    #[cfg(test)]
    /// Number of white (1) pixels.
    pub(crate) fn count_ones(&self) -> u64 {
        self.words.iter().map(|w| u64::from(w.count_ones())).sum()
    }

    /// The image as 8-bit grey: 255 for white bits, 0 for black — the form `cv2.threshold`
    /// and `cv2.dilate` produce, for debugging and comparison.
    pub fn to_gray_image(&self) -> GrayImage {
        GrayImage::from_fn(self.width, self.height, |x, y| {
            image::Luma([if self.get(x, y) { 255 } else { 0 }])
        })
    }

    /// Mask that keeps the valid bits of a row's last word.
    fn last_word_mask(&self) -> u64 {
        match self.width % 64 {
            0 => u64::MAX,
            n => (1u64 << n) - 1,
        }
    }
}

/// Threshold one row of RGB bytes into bits: bit = `gray(pixel) > threshold`, where
/// `k = color::gray_sum_above(threshold)`. `out` has `⌈pixels / 64⌉` words; the bits past
/// the last pixel are left 0.
#[inline(always)]
pub(crate) fn threshold_row(rgb: &[u8], k: u32, out: &mut [u64]) {
    let mut chunks = rgb.chunks_exact(192);
    let mut i = 0;
    for chunk in &mut chunks {
        // 64 pixels: the 64 comparisons into a byte array first (the compiler vectorises
        // this loop for the target), then packed into the word.
        let mut white = [0u8; 64];
        for (w, px) in white.iter_mut().zip(chunk.chunks_exact(3)) {
            *w = u8::from(color::gray_sum(px[0], px[1], px[2]) >= k);
        }
        let mut word = 0u64;
        for (j, w) in white.iter().enumerate() {
            word |= u64::from(*w) << j;
        }
        out[i] = word;
        i += 1;
    }
    let rest = chunks.remainder();
    if !rest.is_empty() {
        let mut word = 0u64;
        for (j, px) in rest.chunks_exact(3).enumerate() {
            word |= u64::from(color::gray_sum(px[0], px[1], px[2]) >= k) << j;
        }
        out[i] = word;
    }
}

/// `buf[p] |= buf[p + s]` for every pixel `p` of a bit row (pixels past the end are 0).
/// Runs in place in ascending order: every word read is still unmodified.
#[inline(always)]
fn or_ahead(buf: &mut [u64], s: usize) {
    let n = buf.len();
    let (q, b) = (s / 64, (s % 64) as u32);
    for i in 0..n {
        let lo = if i + q < n { buf[i + q] } else { 0 };
        let v = if b == 0 {
            lo
        } else {
            let hi = if i + q + 1 < n { buf[i + q + 1] } else { 0 };
            (lo >> b) | (hi << (64 - b))
        };
        buf[i] |= v;
    }
}

/// `buf[p] |= buf[p − s]` for every pixel `p` of a bit row (pixels before 0 are 0).
/// Runs in place in descending order.
#[inline(always)]
fn or_behind(buf: &mut [u64], s: usize) {
    let n = buf.len();
    let (q, b) = (s / 64, (s % 64) as u32);
    for i in (0..n).rev() {
        let hi = if i >= q { buf[i - q] } else { 0 };
        let v = if b == 0 {
            hi
        } else {
            let lo = if i > q { buf[i - q - 1] } else { 0 };
            (hi << b) | (lo >> (64 - b))
        };
        buf[i] |= v;
    }
}

/// OR-window of length `len` (≥ 1) by doubling: after the call `buf[p]` is the OR of the
/// original `buf[p .. p + len]` (`ahead = true`) or `buf[p − len + 1 ..= p]` (`false`).
#[inline(always)]
fn one_sided_window(buf: &mut [u64], len: usize, ahead: bool) {
    let op = if ahead { or_ahead } else { or_behind };
    let mut cover = 1;
    while cover * 2 <= len {
        op(buf, cover);
        cover *= 2;
    }
    if cover < len {
        // Two overlapping windows of length `cover` starting `len − cover` apart.
        op(buf, len - cover);
    }
}

/// OR of each bit with the `len − 1` bits above it inside one word (bits past bit 63
/// count as 0): bit j of the result is `x[j] | … | x[j + len − 1]`. `1 <= len <= 64`.
#[inline(always)]
fn word_window_ahead(x: u64, len: usize) -> u64 {
    let mut v = x;
    let mut cover = 1;
    while cover * 2 <= len {
        v |= v >> cover;
        cover *= 2;
    }
    if cover < len {
        v |= v >> (len - cover);
    }
    v
}

/// The mirror of [`word_window_ahead`]: bit j is `x[j − len + 1] | … | x[j]`.
#[inline(always)]
fn word_window_behind(x: u64, len: usize) -> u64 {
    let mut v = x;
    let mut cover = 1;
    while cover * 2 <= len {
        v |= v << cover;
        cover *= 2;
    }
    if cover < len {
        v |= v << (len - cover);
    }
    v
}

/// Horizontal dilation of one row by radius `r` (window [p−r, p+r]), into `out`;
/// `tmp` is scratch of the same length. `last_mask` clears bits past the row's end.
///
/// For r < 64 each word needs only its two neighbours: with A(x) and B(x) the one-sided
/// windows of length r+1 inside a word ([`word_window_ahead`], [`word_window_behind`]),
/// `out[i] = A(x[i]) | B(x[i]) | B(x[i+1]) << (64 − r) | A(x[i−1]) >> (64 − r)` — the
/// low r bits of B(x[i+1]) are prefix ORs of the next word, the high r bits of A(x[i−1])
/// suffix ORs of the previous one. Larger radii use whole-row doubling passes.
#[inline(always)]
fn dilate_row(row: &[u64], r: usize, last_mask: u64, tmp: &mut [u64], out: &mut [u64]) {
    let n = row.len();
    if r == 0 || n == 0 {
        out.copy_from_slice(row);
        return;
    }
    if r < 64 {
        let len = r + 1;
        let shift = (64 - r) as u32;
        let mut prev_a = 0u64;
        let mut cur_a = word_window_ahead(row[0], len);
        let mut cur_b = word_window_behind(row[0], len);
        for i in 0..n {
            let next = if i + 1 < n { row[i + 1] } else { 0 };
            let next_a = word_window_ahead(next, len);
            let next_b = word_window_behind(next, len);
            out[i] = cur_a | cur_b | (next_b << shift) | (prev_a >> shift);
            prev_a = cur_a;
            cur_a = next_a;
            cur_b = next_b;
        }
    } else {
        out.copy_from_slice(row);
        tmp.copy_from_slice(row);
        one_sided_window(out, r + 1, true);
        one_sided_window(tmp, r + 1, false);
        for (o, t) in out.iter_mut().zip(tmp.iter()) {
            *o |= *t;
        }
    }
    if let Some(last) = out.last_mut() {
        *last &= last_mask;
    }
}

/// Radius beyond which a larger square changes nothing: a window of half-size
/// `max(w, h)` already covers the whole image from any pixel.
fn effective_radius(width: u32, height: u32, radius: u32) -> usize {
    radius.min(width.max(height)) as usize
}

/// One vertical doubling step over whole rows, in place: row y ← row y | row y+s
/// (`ahead`, ascending, so row y+s is still the old one) or row y ← row y | row y−s
/// (descending). Rows outside the image count as 0.
#[inline(always)]
fn vertical_step(words: &mut [u64], wpr: usize, h: usize, s: usize, ahead: bool) {
    if s >= h || wpr == 0 {
        return;
    }
    if ahead {
        for y in 0..h - s {
            let (a, b) = words.split_at_mut((y + s) * wpr);
            for (d, v) in a[y * wpr..(y + 1) * wpr].iter_mut().zip(&b[..wpr]) {
                *d |= *v;
            }
        }
    } else {
        for y in (s..h).rev() {
            let (a, b) = words.split_at_mut(y * wpr);
            for (d, v) in b[..wpr]
                .iter_mut()
                .zip(&a[(y - s) * wpr..(y - s + 1) * wpr])
            {
                *d |= *v;
            }
        }
    }
}

/// Vertical one-sided windows of length `len` over whole rows, in place.
#[inline(always)]
fn vertical_window(img: &mut BitImage, len: usize, ahead: bool) {
    let h = img.height as usize;
    let wpr = img.words_per_row;
    let mut cover = 1;
    while cover * 2 <= len {
        vertical_step(&mut img.words, wpr, h, cover, ahead);
        cover *= 2;
    }
    if cover < len {
        vertical_step(&mut img.words, wpr, h, len - cover, ahead);
    }
}

/// Grey + threshold of a whole image: bit = `gray > threshold` (`cv2.threshold`,
/// `THRESH_BINARY`: strictly greater gives the maximum value).
pub fn threshold_bits(img: &RgbImage, threshold: u8) -> BitImage {
    struct Op<'a>(&'a RgbImage, u8);
    impl KernelUser for Op<'_> {
        type Output = BitImage;
        #[inline(always)]
        fn run(self, threshold_row: impl Fn(&[u8], u32, &mut [u64])) -> BitImage {
            threshold_bits_with(self.0, self.1, threshold_row)
        }
    }
    dispatch(Op(img, threshold))
}

#[inline(always)]
fn threshold_bits_with(
    img: &RgbImage,
    threshold: u8,
    threshold_row: impl Fn(&[u8], u32, &mut [u64]),
) -> BitImage {
    let mut out = BitImage::new(img.width(), img.height());
    let k = color::gray_sum_above(threshold);
    let row_bytes = img.width() as usize * 3;
    if row_bytes == 0 {
        return out;
    }
    for (y, rgb) in img.as_raw().chunks_exact(row_bytes).enumerate() {
        threshold_row(rgb, k, out.row_mut(y as u32));
    }
    out
}

/// Code that runs with a grey + threshold row kernel; see [`dispatch`].
trait KernelUser {
    type Output;
    fn run(self, threshold_row: impl Fn(&[u8], u32, &mut [u64])) -> Self::Output;
}

/// Run `user` with the best row kernel for this CPU, detected at run time: on x86-64 with
/// AVX2 (x86-64-v3) inside `pulp`'s dispatch, so that `user` (inlined) is compiled for that
/// instruction set, with [`x86::threshold_row_v3`]; with SSSE3/SSE4 (x86-64-v2) likewise
/// with [`x86::threshold_row_v2`]; elsewhere with the portable [`threshold_row`] (which
/// the compiler vectorises for the target, e.g. NEON on aarch64). All kernels give the
/// same bits (checked by the property tests).
#[inline(always)]
fn dispatch<U: KernelUser>(user: U) -> U::Output {
    dispatch_up_to(CodePath::Best, user)
}

/// Which row kernel to use (for benchmarks and comparisons; normal calls use the best).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CodePath {
    /// The best the CPU offers (AVX2, then SSSE3/SSE4, then portable).
    #[default]
    Best,
    /// At most the x86-64-v2 (SSSE3/SSE4) kernel.
    X86V2,
    /// The portable code compiled for the baseline instruction set.
    Portable,
}

#[inline(always)]
fn dispatch_up_to<U: KernelUser>(max: CodePath, user: U) -> U::Output {
    #[cfg(target_arch = "x86_64")]
    if max == CodePath::Best
        && let Some(simd) = pulp::x86::V3::try_new()
    {
        struct Run<U>(pulp::x86::V3, U);
        impl<U: KernelUser> pulp::WithSimd for Run<U> {
            type Output = U::Output;
            #[inline(always)]
            fn with_simd<S: pulp::Simd>(self, _: S) -> U::Output {
                let simd = self.0;
                self.1.run(
                    #[inline(always)]
                    |rgb: &[u8], k: u32, out: &mut [u64]| x86::threshold_row_v3(simd, rgb, k, out),
                )
            }
        }
        return pulp::Simd::vectorize(simd, Run(simd, user));
    }
    #[cfg(target_arch = "x86_64")]
    if max != CodePath::Portable
        && let Some(simd) = pulp::x86::V2::try_new()
    {
        struct Run<U>(pulp::x86::V2, U);
        impl<U: KernelUser> pulp::NullaryFnOnce for Run<U> {
            type Output = U::Output;
            #[inline(always)]
            fn call(self) -> U::Output {
                let simd = self.0;
                self.1.run(
                    #[inline(always)]
                    |rgb: &[u8], k: u32, out: &mut [u64]| x86::threshold_row_v2(simd, rgb, k, out),
                )
            }
        }
        return simd.vectorize(Run(simd, user));
    }
    user.run(threshold_row)
}

/// Dilation of a binary image by the (2·`radius`+1)² square, the outside of the image
/// never winning (= `radius` iterations of `cv2.dilate` with a 3×3 kernel).
pub fn dilate_bits(src: &BitImage, radius: u32) -> BitImage {
    let r = effective_radius(src.width, src.height, radius);
    let mut h = BitImage::new(src.width, src.height);
    let mask = src.last_word_mask();
    let mut tmp = vec![0u64; src.words_per_row];
    for y in 0..src.height {
        let (row, out) = (src.row(y), h.row_mut(y));
        dilate_row(row, r, mask, &mut tmp, out);
    }
    if r == 0 {
        return h;
    }
    let mut down = h.clone();
    vertical_window(&mut down, r + 1, true);
    vertical_window(&mut h, r + 1, false);
    for (a, b) in h.words.iter_mut().zip(&down.words) {
        *a |= *b;
    }
    h
}

/// Per region: (first word, last word, mask of the first word, mask of the last word) for
/// the columns `c0..c1` (non-empty).
#[inline(always)]
fn column_masks(c0: u32, c1: u32) -> (usize, usize, u64, u64) {
    let (w0, w1) = ((c0 / 64) as usize, ((c1 - 1) / 64) as usize);
    let m0 = u64::MAX << (c0 % 64);
    let m1 = u64::MAX >> (63 - (c1 - 1) % 64);
    (w0, w1, m0, m1)
}

#[inline(always)]
fn count_range(row: &[u64], (w0, w1, m0, m1): (usize, usize, u64, u64)) -> u64 {
    if w0 == w1 {
        return u64::from((row[w0] & m0 & m1).count_ones());
    }
    let mut n = (row[w0] & m0).count_ones() + (row[w1] & m1).count_ones();
    for w in &row[w0 + 1..w1] {
        n += w.count_ones();
    }
    u64::from(n)
}

/// Black (0) pixels of a binary image in each of the five regions.
pub(crate) fn count_regions(bits: &BitImage) -> RegionCounts {
    count_regions_with(bits.width, bits.height, |y| bits.row(y))
}

#[inline(always)]
fn count_regions_with<'a>(width: u32, height: u32, row: impl Fn(u32) -> &'a [u64]) -> RegionCounts {
    let grid = RegionGrid::new(width, height);
    let mut counts = RegionCounts::default();
    for region in Region::ALL {
        let (rows, cols) = grid.bounds(region);
        let pixels = u64::from(rows.end - rows.start) * u64::from(cols.end - cols.start);
        counts.pixels[region as usize] = pixels;
        if pixels == 0 {
            continue;
        }
        let masks = column_masks(cols.start, cols.end);
        let white: u64 = rows.map(|y| count_range(row(y), masks)).sum();
        counts.black[region as usize] = pixels - white;
    }
    counts
}

/// The intermediate images of one pass of the fast pipeline, for debugging and for the
/// comparison with OpenCV.
#[derive(Clone, Debug)]
pub struct Intermediates {
    /// After grey + threshold (1 = grey above the threshold).
    pub binary: BitImage,
    /// After the dilation.
    pub dilated: BitImage,
    /// Black pixels per region of `dilated`.
    pub counts: RegionCounts,
}

/// The whole pipeline, keeping the intermediate images.
pub fn run_with_intermediates(img: &RgbImage, threshold: u8, radius: u32) -> Intermediates {
    let binary = threshold_bits(img, threshold);
    let dilated = dilate_bits(&binary, radius);
    let counts = count_regions(&dilated);
    Intermediates {
        binary,
        dilated,
        counts,
    }
}

/// Reusable buffers for `region_counts_in`, so that classifying a stream of images of
/// the same size allocates nothing per image.
#[derive(Debug, Default)]
pub struct Workspace {
    down: Vec<u64>,
    up: Vec<u64>,
    row: Vec<u64>,
    tmp: Vec<u64>,
}

/// The whole pipeline, fused: each RGB row is read once, thresholded into bits and dilated
/// horizontally while it is in cache; the vertical pass and the counts follow on the
/// bit-packed image. Returns the black pixels per region after the dilation.
pub(crate) fn region_counts(img: &RgbImage, threshold: u8, radius: u32) -> RegionCounts {
    region_counts_in(&mut Workspace::default(), img, threshold, radius)
}

/// [`region_counts`] with caller-provided buffers, on the best kernel for this CPU
/// (see `dispatch`).
pub(crate) fn region_counts_in(
    ws: &mut Workspace,
    img: &RgbImage,
    threshold: u8,
    radius: u32,
) -> RegionCounts {
    region_counts_on(CodePath::Best, ws, img, threshold, radius)
}

/// `region_counts_in` on at most the given code path (for benchmarks and comparisons).
pub fn region_counts_on(
    path: CodePath,
    ws: &mut Workspace,
    img: &RgbImage,
    threshold: u8,
    radius: u32,
) -> RegionCounts {
    struct Op<'a> {
        ws: &'a mut Workspace,
        img: &'a RgbImage,
        threshold: u8,
        radius: u32,
    }
    impl KernelUser for Op<'_> {
        type Output = RegionCounts;
        #[inline(always)]
        fn run(self, threshold_row: impl Fn(&[u8], u32, &mut [u64])) -> RegionCounts {
            region_counts_fused(
                self.ws,
                self.img,
                self.threshold,
                self.radius,
                threshold_row,
            )
        }
    }
    dispatch_up_to(
        path,
        Op {
            ws,
            img,
            threshold,
            radius,
        },
    )
}

/// The AVX2 grey + threshold kernel.
#[cfg(target_arch = "x86_64")]
pub mod x86 {
    use core::arch::x86_64::{__m128i, __m256i};
    use pulp::x86::{V2, V3};

    /// Per 128-bit lane: 4 pixels (12 bytes) → four 32-bit lanes holding (r, g) as two
    /// 16-bit values; 0x80 makes a zero byte.
    const RG: [u8; 16] = [
        0, 128, 1, 128, 3, 128, 4, 128, 6, 128, 7, 128, 9, 128, 10, 128,
    ];
    /// Per 128-bit lane: 4 pixels → four 32-bit lanes holding b.
    const B: [u8; 16] = [
        2, 128, 128, 128, 5, 128, 128, 128, 8, 128, 128, 128, 11, 128, 128, 128,
    ];

    #[inline(always)]
    fn lanes(x: [u8; 16]) -> __m256i {
        let mut both = [0u8; 32];
        both[..16].copy_from_slice(&x);
        both[16..].copy_from_slice(&x);
        pulp::cast(both)
    }

    #[inline(always)]
    fn load16(bytes: &[u8; 196], at: usize) -> __m128i {
        let mut a = [0u8; 16];
        a.copy_from_slice(&bytes[at..at + 16]);
        pulp::cast(a)
    }

    /// [`threshold_row_v3`] with 128-bit SSSE3 registers: 4 pixels per step (one 16-byte
    /// load, `pshufb`, `pmaddwd`, `movmskps`), sixteen steps per 64-pixel word.
    #[inline(always)]
    pub(crate) fn threshold_row_v2(simd: V2, rgb: &[u8], k: u32, out: &mut [u64]) {
        let sse = simd.sse;
        let sse2 = simd.sse2;
        let ssse3 = simd.ssse3;
        let rg_mask: __m128i = pulp::cast(RG);
        let b_mask: __m128i = pulp::cast(B);
        let w_rg = sse2
            ._mm_set1_epi32(super::color::GRAY_R as i32 | ((super::color::GRAY_G as i32) << 16));
        let w_b = sse2._mm_set1_epi32(super::color::GRAY_B as i32);
        let bound = sse2._mm_set1_epi32(k as i32 - 1);
        let group = |chunk: &[u8; 196], g: usize| -> u64 {
            let v = load16(chunk, 12 * g);
            let rg = ssse3._mm_shuffle_epi8(v, rg_mask);
            let b = ssse3._mm_shuffle_epi8(v, b_mask);
            let s = sse2._mm_add_epi32(sse2._mm_madd_epi16(rg, w_rg), sse2._mm_madd_epi16(b, w_b));
            let white = sse2._mm_cmpgt_epi32(s, bound);
            u64::from(sse._mm_movemask_ps(sse2._mm_castsi128_ps(white)) as u8)
        };
        for (i, o) in out.iter_mut().enumerate() {
            let start = 192 * i;
            *o = match rgb
                .get(start..start + 196)
                .and_then(|c| <&[u8; 196]>::try_from(c).ok())
            {
                Some(chunk) => {
                    let mut word = 0u64;
                    for g in 0..16 {
                        word |= group(chunk, g) << (4 * g);
                    }
                    word
                }
                None => scalar_word(rgb, start, k),
            };
        }
    }

    /// The pixels of one 64-pixel word one by one (the end of a row).
    #[inline(always)]
    fn scalar_word(rgb: &[u8], start: usize, k: u32) -> u64 {
        let mut word = 0u64;
        let end = (start + 192).min(rgb.len());
        for (j, px) in rgb[start.min(end)..end].chunks_exact(3).enumerate() {
            word |= u64::from(super::color::gray_sum(px[0], px[1], px[2]) >= k) << j;
        }
        word
    }

    /// [`super::threshold_row`] with AVX2: for each group of 8 pixels, two 16-byte loads
    /// (pixels 0–3 and 4–7, one per 128-bit lane), `vpshufb` into (r, g) and (b, 0) 16-bit
    /// pairs, `vpmaddwd` with (RY15, GY15) and (BY15, 0) — the exact 32-bit sum of
    /// OpenCV's fixed-point grey — a compare with the bound and `vmovmskps` for 8 bits;
    /// eight groups make one 64-pixel word. A word whose last group would read past the
    /// row (the loads take 4 bytes beyond each 4-pixel half) is done pixel by pixel.
    #[inline(always)]
    pub(crate) fn threshold_row_v3(simd: V3, rgb: &[u8], k: u32, out: &mut [u64]) {
        let avx = simd.avx;
        let avx2 = simd.avx2;
        let rg_mask = lanes(RG);
        let b_mask = lanes(B);
        let w_rg = avx
            ._mm256_set1_epi32(super::color::GRAY_R as i32 | ((super::color::GRAY_G as i32) << 16));
        let w_b = avx._mm256_set1_epi32(super::color::GRAY_B as i32);
        // s >= k ⇔ s > k − 1 (k >= 2¹⁴, so k − 1 is a positive i32).
        let bound = avx._mm256_set1_epi32(k as i32 - 1);
        let group = |chunk: &[u8; 196], g: usize| -> u64 {
            let v = avx._mm256_set_m128i(load16(chunk, 24 * g + 12), load16(chunk, 24 * g));
            let rg = avx2._mm256_shuffle_epi8(v, rg_mask);
            let b = avx2._mm256_shuffle_epi8(v, b_mask);
            let s = avx2._mm256_add_epi32(
                avx2._mm256_madd_epi16(rg, w_rg),
                avx2._mm256_madd_epi16(b, w_b),
            );
            let white = avx2._mm256_cmpgt_epi32(s, bound);
            u64::from(avx._mm256_movemask_ps(avx._mm256_castsi256_ps(white)) as u8)
        };
        for (i, o) in out.iter_mut().enumerate() {
            let start = 192 * i;
            *o = match rgb
                .get(start..start + 196)
                .and_then(|c| <&[u8; 196]>::try_from(c).ok())
            {
                Some(chunk) => {
                    group(chunk, 0)
                        | group(chunk, 1) << 8
                        | group(chunk, 2) << 16
                        | group(chunk, 3) << 24
                        | group(chunk, 4) << 32
                        | group(chunk, 5) << 40
                        | group(chunk, 6) << 48
                        | group(chunk, 7) << 56
                }
                None => scalar_word(rgb, start, k),
            };
        }
    }
}

/// The fused pipeline itself (see [`region_counts_in`]).
#[inline(always)]
fn region_counts_fused(
    ws: &mut Workspace,
    img: &RgbImage,
    threshold: u8,
    radius: u32,
    threshold_row: impl Fn(&[u8], u32, &mut [u64]),
) -> RegionCounts {
    let (width, height) = img.dimensions();
    let wpr = (width as usize).div_ceil(64);
    let n = wpr * height as usize;
    let r = effective_radius(width, height, radius);
    let k = color::gray_sum_above(threshold);
    let mask = match width % 64 {
        0 => u64::MAX,
        m => (1u64 << m) - 1,
    };
    ws.down.clear();
    ws.down.resize(n, 0);
    ws.row.clear();
    ws.row.resize(wpr, 0);
    ws.tmp.clear();
    ws.tmp.resize(wpr, 0);
    let row_bytes = width as usize * 3;
    if row_bytes > 0 {
        for (y, rgb) in img.as_raw().chunks_exact(row_bytes).enumerate() {
            threshold_row(rgb, k, &mut ws.row);
            let out = &mut ws.down[y * wpr..(y + 1) * wpr];
            dilate_row(&ws.row, r, mask, &mut ws.tmp, out);
        }
    }
    if r > 0 {
        ws.up.clear();
        ws.up.extend_from_slice(&ws.down);
        let mut down = BitImage {
            width,
            height,
            words_per_row: wpr,
            words: std::mem::take(&mut ws.down),
        };
        let mut up = BitImage {
            width,
            height,
            words_per_row: wpr,
            words: std::mem::take(&mut ws.up),
        };
        vertical_window(&mut down, r + 1, true);
        vertical_window(&mut up, r + 1, false);
        for (a, b) in down.words.iter_mut().zip(&up.words) {
            *a |= *b;
        }
        let counts = count_regions_with(width, height, |y| down.row(y));
        ws.down = down.words;
        ws.up = up.words;
        counts
    } else {
        let bits = BitImage {
            width,
            height,
            words_per_row: wpr,
            words: std::mem::take(&mut ws.down),
        };
        let counts = count_regions_with(width, height, |y| bits.row(y));
        ws.down = bits.words;
        counts
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row_from(bits: &[bool]) -> Vec<u64> {
        let mut v = vec![0u64; bits.len().div_ceil(64)];
        for (i, b) in bits.iter().enumerate() {
            if *b {
                v[i / 64] |= 1 << (i % 64);
            }
        }
        v
    }

    #[test]
    fn row_dilation_matches_a_loop() {
        for len in [1usize, 5, 63, 64, 65, 130, 200] {
            for r in [0usize, 1, 2, 3, 7, 8, 40, 70] {
                let bits: Vec<bool> = (0..len).map(|i| (i * 7919 + r) % 23 == 0).collect();
                let want: Vec<bool> = (0..len)
                    .map(|p| (p.saturating_sub(r)..=(p + r).min(len - 1)).any(|q| bits[q]))
                    .collect();
                let row = row_from(&bits);
                let mut out = vec![0; row.len()];
                let mut tmp = vec![0; row.len()];
                let mask = if len % 64 == 0 {
                    u64::MAX
                } else {
                    (1 << (len % 64)) - 1
                };
                dilate_row(&row, r, mask, &mut tmp, &mut out);
                assert_eq!(out, row_from(&want), "len {len} r {r}");
            }
        }
    }

    #[test]
    fn single_white_pixel_becomes_a_clipped_square() {
        let mut img = BitImage::new(40, 30);
        img.row_mut(2)[0] |= 1 << 3; // (3, 2)
        let d = dilate_bits(&img, 7);
        for y in 0..30 {
            for x in 0..40 {
                assert_eq!(d.get(x, y), x <= 10 && y <= 9, "({x}, {y})");
            }
        }
        assert_eq!(d.count_ones(), 11 * 10);
    }

    mod prop {
        use super::super::*;
        use crate::vision::reference;
        use image::Rgb;
        use proptest::prelude::*;
        use rand::{RngExt, SeedableRng};

        /// A random image whose bright pixels are sparse, so that dilation has work to do.
        fn sparse_image(w: u32, h: u32, bright_per_mille: u32, seed: u64) -> RgbImage {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            RgbImage::from_fn(w, h, |_, _| {
                if rng.random_range(0..1000) < bright_per_mille {
                    Rgb([
                        rng.random_range(120..=255),
                        rng.random_range(120..=255),
                        rng.random(),
                    ])
                } else {
                    Rgb([
                        rng.random_range(0..170),
                        rng.random_range(0..150),
                        rng.random(),
                    ])
                }
            })
        }

        fn dims() -> impl Strategy<Value = (u32, u32)> {
            prop_oneof![
                (1u32..40, 1u32..40),
                (1u32..200, 1u32..120),
                (
                    prop::sample::select(vec![63u32, 64, 65, 127, 128, 129, 191, 193]),
                    1u32..70
                ),
            ]
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(200))]

            #[test]
            fn fast_path_equals_reference(
                (w, h) in dims(),
                bright in 0u32..80,
                threshold in prop_oneof![Just(150u8), any::<u8>()],
                radius in prop_oneof![4 => Just(7u32), 4 => 0u32..20, 1 => 60u32..80],
                seed in any::<u64>(),
            ) {
                let img = sparse_image(w, h, bright, seed);
                let gray = reference::gray(&img);
                let binary = reference::threshold(&gray, threshold);
                let dilated = reference::dilate(&binary, radius);
                let ours = run_with_intermediates(&img, threshold, radius);
                prop_assert_eq!(ours.binary.to_gray_image(), binary);
                prop_assert_eq!(&threshold_bits_with(&img, threshold, threshold_row), &ours.binary);
                // Each CPU-specific kernel this machine has, called directly.
                #[cfg(target_arch = "x86_64")]
                {
                    if let Some(v2) = pulp::x86::V2::try_new() {
                        let bits = v2.vectorize(|| threshold_bits_with(&img, threshold, |a: &[u8], k, o: &mut [u64]| x86::threshold_row_v2(v2, a, k, o)));
                        prop_assert_eq!(&bits, &ours.binary);
                    }
                    if let Some(v3) = pulp::x86::V3::try_new() {
                        let bits = v3.vectorize(|| threshold_bits_with(&img, threshold, |a: &[u8], k, o: &mut [u64]| x86::threshold_row_v3(v3, a, k, o)));
                        prop_assert_eq!(&bits, &ours.binary);
                    }
                }
                prop_assert_eq!(ours.dilated.to_gray_image(), dilated.clone());
                let counts = reference::count_regions(&dilated);
                prop_assert_eq!(ours.counts, counts);
                prop_assert_eq!(region_counts(&img, threshold, radius), counts);
                let mut ws = Workspace::default();
                prop_assert_eq!(region_counts_in(&mut ws, &img, threshold, radius), counts);
                for path in [CodePath::Best, CodePath::X86V2, CodePath::Portable] {
                    prop_assert_eq!(region_counts_on(path, &mut ws, &img, threshold, radius), counts);
                }
                // The same code outside the CPU dispatch (the baseline instruction set).
                prop_assert_eq!(region_counts_fused(&mut ws, &img, threshold, radius, threshold_row), counts);
                // Reusing the workspace for another size gives the same answer too.
                let other = sparse_image(h, w, bright, seed ^ 1);
                prop_assert_eq!(
                    region_counts_in(&mut ws, &other, threshold, radius),
                    reference::region_counts(&other, threshold, radius)
                );
            }

            /// Seven (r) iterations of the 3×3 dilation are one (2r+1)² square dilation:
            /// checked against imageproc's L∞ dilation, an independent implementation.
            #[test]
            fn iterated_3x3_is_one_square(
                (w, h) in dims(),
                bright in 0u32..60,
                radius in 0u32..12,
                seed in any::<u64>(),
            ) {
                let img = sparse_image(w, h, bright, seed);
                let binary = reference::threshold(&reference::gray(&img), 150);
                let iterated = reference::dilate(&binary, radius);
                if binary.pixels().all(|p| p.0[0] == 0) {
                    // imageproc's distance transform calls "no foreground at all" a distance
                    // of min(w + h, 255), so it cannot be the reference for this case.
                    prop_assert!(iterated.pixels().all(|p| p.0[0] == 0));
                } else {
                    let square = imageproc::morphology::dilate(
                        &binary, imageproc::distance_transform::Norm::LInf, radius as u8);
                    prop_assert_eq!(iterated, square);
                }
            }
        }
    }
}
