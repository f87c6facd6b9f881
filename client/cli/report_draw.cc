#include "client/cli/report_draw.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>

#include "absl/strings/str_format.h"
#include "client/cli/thin_summary.h"

namespace meshgauge::cli {
namespace {

constexpr Rgb kInk = {20, 20, 20};
constexpr int kGlyphW = 5, kGlyphH = 7;

// Rows of each glyph, 5 bits each, the most significant bit leftmost.
const std::map<char, std::array<uint8_t, kGlyphH>>& Glyphs() {
  static const auto* glyphs = new std::map<char, std::array<uint8_t, kGlyphH>>{
      {'0', {0x0e, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0e}},
      {'1', {0x04, 0x0c, 0x04, 0x04, 0x04, 0x04, 0x0e}},
      {'2', {0x0e, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1f}},
      {'3', {0x1f, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0e}},
      {'4', {0x02, 0x06, 0x0a, 0x12, 0x1f, 0x02, 0x02}},
      {'5', {0x1f, 0x10, 0x1e, 0x01, 0x01, 0x11, 0x0e}},
      {'6', {0x06, 0x08, 0x10, 0x1e, 0x11, 0x11, 0x0e}},
      {'7', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08}},
      {'8', {0x0e, 0x11, 0x11, 0x0e, 0x11, 0x11, 0x0e}},
      {'9', {0x0e, 0x11, 0x11, 0x0f, 0x01, 0x02, 0x0c}},
      {'A', {0x0e, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11}},
      {'B', {0x1e, 0x11, 0x11, 0x1e, 0x11, 0x11, 0x1e}},
      {'C', {0x0e, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0e}},
      {'D', {0x1c, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1c}},
      {'E', {0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x1f}},
      {'F', {0x1f, 0x10, 0x10, 0x1e, 0x10, 0x10, 0x10}},
      {'G', {0x0e, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0f}},
      {'H', {0x11, 0x11, 0x11, 0x1f, 0x11, 0x11, 0x11}},
      {'I', {0x0e, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0e}},
      {'J', {0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0c}},
      {'K', {0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11}},
      {'L', {0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1f}},
      {'M', {0x11, 0x1b, 0x15, 0x15, 0x11, 0x11, 0x11}},
      {'N', {0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11}},
      {'O', {0x0e, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e}},
      {'P', {0x1e, 0x11, 0x11, 0x1e, 0x10, 0x10, 0x10}},
      {'Q', {0x0e, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0d}},
      {'R', {0x1e, 0x11, 0x11, 0x1e, 0x14, 0x12, 0x11}},
      {'S', {0x0f, 0x10, 0x10, 0x0e, 0x01, 0x01, 0x1e}},
      {'T', {0x1f, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04}},
      {'U', {0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0e}},
      {'V', {0x11, 0x11, 0x11, 0x11, 0x11, 0x0a, 0x04}},
      {'W', {0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0a}},
      {'X', {0x11, 0x11, 0x0a, 0x04, 0x0a, 0x11, 0x11}},
      {'Y', {0x11, 0x11, 0x0a, 0x04, 0x04, 0x04, 0x04}},
      {'Z', {0x1f, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1f}},
      {'.', {0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x0c}},
      {',', {0x00, 0x00, 0x00, 0x00, 0x0c, 0x04, 0x08}},
      {'-', {0x00, 0x00, 0x00, 0x1f, 0x00, 0x00, 0x00}},
      {'+', {0x00, 0x04, 0x04, 0x1f, 0x04, 0x04, 0x00}},
      {'%', {0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03}},
      {':', {0x00, 0x0c, 0x0c, 0x00, 0x0c, 0x0c, 0x00}},
      {'(', {0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02}},
      {')', {0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08}},
      {'/', {0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00}},
      {'_', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1f}},
      {'=', {0x00, 0x00, 0x1f, 0x00, 0x1f, 0x00, 0x00}},
      {'<', {0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02}},
      {'>', {0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08}},
      {' ', {0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}},
  };
  return *glyphs;
}

void FillRect(Image& image, int x0, int y0, int x1, int y1, Rgb color) {
  for (int y = std::max(0, y0); y < std::min(image.height, y1); ++y) {
    for (int x = std::max(0, x0); x < std::min(image.width, x1); ++x) {
      image.at(x, y) = color;
    }
  }
}

void Blit(Image& dst, const Image& src, int x0, int y0) {
  for (int y = 0; y < src.height; ++y) {
    for (int x = 0; x < src.width; ++x) {
      if (dst.contains(x0 + x, y0 + y)) dst.at(x0 + x, y0 + y) = src.at(x, y);
    }
  }
}

std::string Number(double v) { return absl::StrFormat("%.4g", v); }

}  // namespace

int TextWidth(std::string_view text, int scale) {
  return static_cast<int>(text.size()) * (kGlyphW + 1) * scale;
}

void DrawText(Image& image, int x, int y, std::string_view text, Rgb color,
              int scale) {
  for (char raw : text) {
    const char c =
        static_cast<char>(std::toupper(static_cast<unsigned char>(raw)));
    if (auto it = Glyphs().find(c); it != Glyphs().end()) {
      for (int row = 0; row < kGlyphH; ++row) {
        for (int col = 0; col < kGlyphW; ++col) {
          if (!(it->second[row] >> (kGlyphW - 1 - col) & 1)) continue;
          FillRect(image, x + col * scale, y + row * scale,
                   x + (col + 1) * scale, y + (row + 1) * scale, color);
        }
      }
    }
    x += (kGlyphW + 1) * scale;
  }
}

// The value a fraction f of the way from lo to hi, without overflow.
double Lerp(double lo, double hi, double f) { return lo * (1 - f) + hi * f; }

Image ComposeViews(const std::vector<RenderedView>& views,
                   const ColorScale& scale, double t_min,
                   std::string_view above_label) {
  const int cols = views.size() > 1 ? 2 : 1;
  const int rows = (static_cast<int>(views.size()) + cols - 1) / cols;
  const int vw = views.empty() ? 0 : views[0].image.width;
  const int vh = views.empty() ? 0 : views[0].image.height;
  constexpr int kGap = 8, kTitle = 24;
  // Room right of the bar for its longest label (tick values or t_min's).
  int labels = TextWidth("NO VALUE", 2);
  for (int k = 0; k <= 4; ++k) {
    labels = std::max(labels,
                      TextWidth(Number(Lerp(scale.lo, scale.hi, k / 4.0)), 2));
  }
  labels = std::max(labels, TextWidth("T_MIN " + Number(t_min), 2));
  const std::string above =
      above_label.empty() ? "> " + Number(scale.hi) : std::string(above_label);
  if (scale.overflow) labels = std::max(labels, TextWidth(above, 2));
  const int kBar = std::max(210, 16 + 28 + 10 + labels + 8);
  const int cell_w = vw + kGap, cell_h = vh + kTitle + kGap;
  Image sheet(cols * cell_w + kBar, std::max(rows * cell_h, 320));
  for (size_t i = 0; i < views.size(); ++i) {
    const int x0 = static_cast<int>(i % cols) * cell_w;
    const int y0 = static_cast<int>(i / cols) * cell_h;
    DrawText(sheet, x0 + 4, y0 + 5, views[i].name, kInk, 2);
    Blit(sheet, views[i].image, x0, y0 + kTitle);
  }
  // The colour bar: hi at the top, lo at the bottom; above it the overflow
  // colour's swatch, apart, when values above hi have their own colour.
  const int bx = cols * cell_w + 16, bw = 28;
  const int top = scale.overflow ? 70 : 40, bottom = sheet.height - 70;
  DrawText(sheet, bx, 10, "THICKNESS", kInk, 2);
  if (scale.overflow) {
    FillRect(sheet, bx, 36, bx + bw, 54, kOverflowColor);
    DrawText(sheet, bx + bw + 10, 38, above, kInk, 2);
  }
  for (int y = top; y <= bottom; ++y) {
    const double s = 1.0 - static_cast<double>(y - top) / (bottom - top);
    FillRect(sheet, bx, y, bx + bw, y + 1, ThicknessColor(s));
  }
  auto y_of = [&](double t) {
    return top +
           static_cast<int>(std::lround(
               (1 - std::clamp(scale.Position(t), 0.0, 1.0)) * (bottom - top)));
  };
  const double p = scale.Position(t_min);
  const bool inside = p >= 0 && p <= 1;
  const int ty = y_of(t_min);
  for (int k = 0; k <= 4; ++k) {
    const double t = Lerp(scale.lo, scale.hi, k / 4.0);
    const int y = y_of(t);
    FillRect(sheet, bx + bw, y, bx + bw + 6, y + 1, kInk);
    // The t_min label has the room near its mark.
    if (inside && std::abs(y - ty) < 22) continue;
    DrawText(sheet, bx + bw + 10, y - 7, Number(t), kInk, 2);
  }
  const std::string mark = "T_MIN " + Number(t_min);
  if (inside) {
    FillRect(sheet, bx - 6, ty - 1, bx + bw + 6, ty + 2, kThinOutline);
    DrawText(sheet, bx + bw + 10, ty - 7, mark, kThinOutline, 2);
  } else {
    DrawText(sheet, bx, p > 1 ? 26 : bottom + 8,
             mark + (p > 1 ? " ABOVE" : " BELOW"), kThinOutline, 1);
  }
  FillRect(sheet, bx, sheet.height - 30, bx + bw, sheet.height - 12,
           kNoValueGrey);
  DrawText(sheet, bx + bw + 10, sheet.height - 28, "NO VALUE", kInk, 2);
  return sheet;
}

Image DrawHistogram(const AreaHistogram& histogram, const ColorScale& scale,
                    double t_min, double thin_share, bool curve,
                    double above_area, std::string_view above_label) {
  // The bins' own areas: the last bin without what lies above the range.
  std::vector<double> area = histogram.area;
  above_area = scale.overflow ? std::max(above_area, 0.0) : 0;
  if (!area.empty()) area.back() = std::max(area.back() - above_area, 0.0);
  double max_area = above_area;
  for (double a : area) max_area = std::max(max_area, a);
  int label_width = 0;
  for (int k = 0; k <= 4; ++k) {
    label_width = std::max(label_width, TextWidth(Number(max_area * k / 4), 2));
  }
  constexpr int kW = 800, kH = 420, kTop = 50, kBottom = 60;
  const int kRight = scale.overflow ? 130 : 50;
  const int kLeft = label_width + 24;
  Image image(kW, kH);
  const int pw = kW - kLeft - kRight, ph = kH - kTop - kBottom;
  const int bins = static_cast<int>(area.size());
  auto x_of = [&](double t) {
    const double f = (t - histogram.lo) / (histogram.hi - histogram.lo);
    return kLeft + static_cast<int>(std::lround(f * pw));
  };
  for (int k = 0; k < bins && max_area > 0; ++k) {
    const int x0 = kLeft + k * pw / bins, x1 = kLeft + (k + 1) * pw / bins;
    const int height =
        static_cast<int>(std::lround(area[k] / max_area * ph));
    const double center = Lerp(histogram.lo, histogram.hi, (k + 0.5) / bins);
    FillRect(image, x0, kTop + ph - height, std::max(x0 + 1, x1 - 1), kTop + ph,
             scale(center));
  }
  FillRect(image, kLeft - 2, kTop, kLeft, kTop + ph + 2, kInk);
  FillRect(image, kLeft - 2, kTop + ph, kLeft + pw, kTop + ph + 2, kInk);
  for (int k = 0; k <= 4; ++k) {
    const int x = kLeft + pw * k / 4;
    FillRect(image, x, kTop + ph + 2, x + 1, kTop + ph + 8, kInk);
    const std::string label = Number(Lerp(histogram.lo, histogram.hi, k / 4.0));
    DrawText(
        image,
        std::clamp(x - TextWidth(label, 2) / 2, 0, kW - TextWidth(label, 2)),
        kTop + ph + 12, label, kInk, 2);
    if (max_area <= 0) continue;
    const int y = kTop + ph - ph * k / 4;
    FillRect(image, kLeft - 8, y, kLeft - 2, y + 1, kInk);
    const std::string area = Number(max_area * k / 4);
    DrawText(image, kLeft - 12 - TextWidth(area, 2), y - 7, area, kInk, 2);
  }
  if (scale.overflow) {
    // The measure above the range: one bar apart, named.
    const int x0 = kLeft + pw + 44, x1 = x0 + 32;
    const int height =
        max_area > 0 ? static_cast<int>(std::lround(above_area / max_area * ph))
                     : 0;
    FillRect(image, x0, kTop + ph - height, x1, kTop + ph, kOverflowColor);
    FillRect(image, x0 - 4, kTop + ph, x1 + 4, kTop + ph + 2, kInk);
    const std::string label = above_label.empty()
                                  ? "> " + Number(scale.hi)
                                  : std::string(above_label);
    DrawText(image,
             std::min((x0 + x1) / 2 - TextWidth(label, 2) / 2,
                      kW - 4 - TextWidth(label, 2)),
             kTop + ph - height - 20, label, kInk, 2);
  }
  if (max_area <= 0) {
    DrawText(image, kLeft + pw / 2 - TextWidth("NO VALUES", 2) / 2,
             kTop + ph / 2, "NO VALUES", kInk, 2);
  }
  if (t_min >= histogram.lo && t_min <= histogram.hi) {
    const int tx = x_of(t_min);
    FillRect(image, tx - 1, kTop - 6, tx + 2, kTop + ph, kThinOutline);
  }
  DrawText(image, 12, 12,
           absl::StrFormat("%s PER THICKNESS BIN: %s %% BELOW T_MIN %s",
                           curve ? "LENGTH" : "AREA", Percent(thin_share),
                           Number(t_min)),
           kInk, 2);
  DrawText(image, kLeft + pw / 2 - TextWidth("THICKNESS", 2) / 2, kH - 22,
           "THICKNESS", kInk, 2);
  return image;
}

}  // namespace meshgauge::cli
