#include "bench/svg_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace fogmap {

namespace {

bool drawable(const PlotPoint& p) {
    return std::isfinite(p.x) && std::isfinite(p.y) && p.x > 0.0 && p.y > 0.0;
}

std::string escape(const std::string& s) {
    std::string out;
    for (char c : s) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

std::string fmt(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
}

std::string tick_label(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v);
    return buf;
}

/// log10 range of one axis: padded by 5% of the span (at least 0.1 decade each side).
struct LogRange {
    double lo = 0.0, hi = 1.0;
    void fit(double vmin, double vmax) {
        if (!(vmin <= vmax)) {
            lo = 0.0;
            hi = 1.0;
            return;
        }
        lo = std::log10(vmin);
        hi = std::log10(vmax);
        const double pad = std::max(0.05 * (hi - lo), 0.1);
        lo -= pad;
        hi += pad;
    }
    double span() const { return hi - lo; }
};

/// Tick values inside [lo, hi] (log10): every decade; with 2 and 5 when the range is under
/// three decades; and 1..9 minor ticks (unlabelled) always.
struct Tick {
    double value;
    bool labelled, major;
};
std::vector<Tick> ticks(const LogRange& r) {
    std::vector<Tick> out;
    const bool mid_labels = r.span() < 3.0;
    for (int decade = int(std::floor(r.lo)); decade <= int(std::ceil(r.hi)); ++decade) {
        for (int m = 1; m <= 9; ++m) {
            const double v = m * std::pow(10.0, decade);
            const double lv = std::log10(v);
            if (lv < r.lo || lv > r.hi) continue;
            out.push_back({v, m == 1 || (mid_labels && (m == 2 || m == 5)), m == 1});
        }
    }
    return out;
}

}  // namespace

std::string svg_log_log(const LogLogPlot& plot) {
    const double w = plot.width, h = plot.height;
    const double left = 80, right = 20, top = 40, bottom = 60;
    const double pw = w - left - right, ph = h - top - bottom;

    double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
    for (const PlotSeries& s : plot.series) {
        for (const PlotPoint& p : s.points) {
            if (!drawable(p)) continue;
            xmin = std::min(xmin, p.x);
            xmax = std::max(xmax, p.x);
            ymin = std::min(ymin, p.y);
            ymax = std::max(ymax, p.y);
        }
    }
    LogRange xr, yr;
    xr.fit(xmin, xmax);
    yr.fit(ymin, ymax);
    const auto sx = [&](double x) { return left + (std::log10(x) - xr.lo) / xr.span() * pw; };
    const auto sy = [&](double y) { return top + ph - (std::log10(y) - yr.lo) / yr.span() * ph; };

    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << plot.width << "\" height=\""
      << plot.height << "\" viewBox=\"0 0 " << plot.width << " " << plot.height
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
    o << "<rect x=\"0\" y=\"0\" width=\"" << plot.width << "\" height=\"" << plot.height
      << "\" fill=\"white\"/>\n";
    o << "<text x=\"" << fmt(w / 2) << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">"
      << escape(plot.title) << "</text>\n";

    // Grid, ticks and tick labels.
    o << "<g stroke-width=\"1\">\n";
    for (const Tick& t : ticks(xr)) {
        const double x = sx(t.value);
        o << "<line x1=\"" << fmt(x) << "\" y1=\"" << fmt(top) << "\" x2=\"" << fmt(x) << "\" y2=\""
          << fmt(top + ph) << "\" stroke=\"" << (t.major ? "#d0d0d0" : "#eeeeee") << "\"/>\n";
        o << "<line x1=\"" << fmt(x) << "\" y1=\"" << fmt(top + ph) << "\" x2=\"" << fmt(x)
          << "\" y2=\"" << fmt(top + ph + (t.major ? 6 : 3)) << "\" stroke=\"black\"/>\n";
        if (t.labelled)
            o << "<text x=\"" << fmt(x) << "\" y=\"" << fmt(top + ph + 20)
              << "\" text-anchor=\"middle\">" << tick_label(t.value) << "</text>\n";
    }
    for (const Tick& t : ticks(yr)) {
        const double y = sy(t.value);
        o << "<line x1=\"" << fmt(left) << "\" y1=\"" << fmt(y) << "\" x2=\"" << fmt(left + pw)
          << "\" y2=\"" << fmt(y) << "\" stroke=\"" << (t.major ? "#d0d0d0" : "#eeeeee")
          << "\"/>\n";
        o << "<line x1=\"" << fmt(left - (t.major ? 6 : 3)) << "\" y1=\"" << fmt(y) << "\" x2=\""
          << fmt(left) << "\" y2=\"" << fmt(y) << "\" stroke=\"black\"/>\n";
        if (t.labelled)
            o << "<text x=\"" << fmt(left - 9) << "\" y=\"" << fmt(y + 4)
              << "\" text-anchor=\"end\">" << tick_label(t.value) << "</text>\n";
    }
    o << "</g>\n";
    o << "<rect x=\"" << fmt(left) << "\" y=\"" << fmt(top) << "\" width=\"" << fmt(pw)
      << "\" height=\"" << fmt(ph) << "\" fill=\"none\" stroke=\"black\"/>\n";
    o << "<text x=\"" << fmt(left + pw / 2) << "\" y=\"" << fmt(h - 15)
      << "\" text-anchor=\"middle\">" << escape(plot.x_label) << "</text>\n";
    o << "<text transform=\"translate(18," << fmt(top + ph / 2)
      << ") rotate(-90)\" text-anchor=\"middle\">" << escape(plot.y_label) << "</text>\n";

    // Series: lines first, then markers on top.
    for (const PlotSeries& s : plot.series) {
        std::vector<PlotPoint> pts;
        for (const PlotPoint& p : s.points)
            if (drawable(p)) pts.push_back(p);
        if (s.line == PlotLine::None || pts.empty()) continue;
        std::vector<PlotPoint> path;
        if (s.line == PlotLine::Step) {
            for (size_t i = 0; i < pts.size(); ++i) {
                if (i > 0) path.push_back({pts[i].x, pts[i - 1].y});
                path.push_back(pts[i]);
            }
            path.push_back({std::pow(10.0, xr.hi), pts.back().y});
        } else {
            path = pts;
        }
        o << "<polyline fill=\"none\" stroke=\"" << escape(s.color) << "\" stroke-width=\"2\""
          << " points=\"";
        for (size_t i = 0; i < path.size(); ++i)
            o << (i ? " " : "") << fmt(sx(path[i].x)) << "," << fmt(sy(path[i].y));
        o << "\"><title>" << escape(s.label) << "</title></polyline>\n";
    }
    for (const PlotSeries& s : plot.series) {
        if (s.marker == PlotMarker::None) continue;
        for (const PlotPoint& p : s.points) {
            if (!drawable(p)) continue;
            const double x = sx(p.x), y = sy(p.y);
            if (s.marker == PlotMarker::Circle)
                o << "<circle cx=\"" << fmt(x) << "\" cy=\"" << fmt(y) << "\" r=\"4\" fill=\""
                  << escape(s.color) << "\" fill-opacity=\"0.75\" stroke=\"black\""
                  << " stroke-width=\"0.5\"/>\n";
            else
                o << "<rect x=\"" << fmt(x - 4) << "\" y=\"" << fmt(y - 4)
                  << "\" width=\"8\" height=\"8\" fill=\"" << escape(s.color)
                  << "\" fill-opacity=\"0.75\" stroke=\"black\" stroke-width=\"0.5\"/>\n";
        }
    }

    // Legend, top right inside the plot area.
    const double lw = 250, row = 18, lx = left + pw - lw - 8, ly = top + 8;
    o << "<g>\n<rect x=\"" << fmt(lx) << "\" y=\"" << fmt(ly) << "\" width=\"" << fmt(lw)
      << "\" height=\"" << fmt(row * plot.series.size() + 8)
      << "\" fill=\"white\" fill-opacity=\"0.9\" stroke=\"#888888\"/>\n";
    for (size_t i = 0; i < plot.series.size(); ++i) {
        const PlotSeries& s = plot.series[i];
        const double cy = ly + 4 + row * (i + 0.5), cx = lx + 18;
        if (s.line != PlotLine::None)
            o << "<line x1=\"" << fmt(cx - 12) << "\" y1=\"" << fmt(cy) << "\" x2=\""
              << fmt(cx + 12) << "\" y2=\"" << fmt(cy) << "\" stroke=\"" << escape(s.color)
              << "\" stroke-width=\"2\"/>\n";
        if (s.marker == PlotMarker::Circle)
            o << "<circle cx=\"" << fmt(cx) << "\" cy=\"" << fmt(cy) << "\" r=\"4\" fill=\""
              << escape(s.color) << "\" stroke=\"black\" stroke-width=\"0.5\"/>\n";
        else if (s.marker == PlotMarker::Square)
            o << "<rect x=\"" << fmt(cx - 4) << "\" y=\"" << fmt(cy - 4)
              << "\" width=\"8\" height=\"8\" fill=\"" << escape(s.color)
              << "\" stroke=\"black\" stroke-width=\"0.5\"/>\n";
        o << "<text x=\"" << fmt(cx + 20) << "\" y=\"" << fmt(cy + 4) << "\">" << escape(s.label)
          << "</text>\n";
    }
    o << "</g>\n</svg>\n";
    return o.str();
}

}  // namespace fogmap
