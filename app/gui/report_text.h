// A report's text (a solve's or an export's summary.txt) laid out for
// reading on a page: its "  label:  value" lines as a two-column table whose
// values wrap in their own column (a label never wraps into the value), the
// other lines across both columns. The text itself is not changed.
#pragma once

#include <QString>
#include <QStringList>

namespace scanbench {

struct ReportLine {
  QString label;  // "" = a line across both columns
  QString value;
};
// Each line of `report`: "  frames:       10 LEDs + dark" -> {"frames", "10 LEDs + dark"};
// a label is at most 24 characters after the indent, without ", ; ( )".
QList<ReportLine> ReportLines(const QString& report);
// The lines as an HTML table (escaped), for a QTextBrowser.
QString ReportHtml(const QString& report);

}  // namespace scanbench
