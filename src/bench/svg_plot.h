#pragma once
// A plain SVG log-log scatter/line plot, written as text with no other software: decade ticks
// (and 2, 5 minor labels when the range is narrow), axis labels, markers, straight or step
// polylines and a legend. Points with a non-positive or non-finite coordinate cannot be shown
// on log axes and are left out. Pure function; thread-safe.

#include <string>
#include <vector>

namespace fogmap {

struct PlotPoint {
    double x = 0.0, y = 0.0;
};

enum class PlotMarker { None, Circle, Square };
/// Straight: segments between consecutive points. Step: the best-so-far staircase of a Pareto
/// frontier (horizontal to the next point's x, then vertical), extended to the right edge.
enum class PlotLine { None, Straight, Step };

struct PlotSeries {
    std::string label;              ///< legend text
    std::string color = "#1f77b4";  ///< SVG colour
    PlotMarker marker = PlotMarker::Circle;
    PlotLine line = PlotLine::None;
    std::vector<PlotPoint> points;  ///< drawn in this order (lines: sort by x first)
};

struct LogLogPlot {
    std::string title, x_label, y_label;
    int width = 760, height = 500;  ///< pixels
    std::vector<PlotSeries> series;
};

/// The plot as a complete SVG document (starts with "<svg"); lines are <polyline> elements,
/// markers <circle>/<rect>. Axes span all drawable points, padded; an empty plot spans 1..10.
std::string svg_log_log(const LogLogPlot& plot);

}  // namespace fogmap
