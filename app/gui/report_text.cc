#include "app/gui/report_text.h"

#include <QRegularExpression>

namespace scanbench {

QList<ReportLine> ReportLines(const QString& report) {
  static const QRegularExpression kLabelled(QStringLiteral("^\\s+([^:,;()]{1,24}):\\s+(\\S.*)$"));
  QList<ReportLine> lines;
  for (const QString& line : report.split(QLatin1Char('\n'))) {
    if (line.trimmed().isEmpty()) continue;
    const QRegularExpressionMatch match = kLabelled.match(line);
    if (match.hasMatch()) {
      lines.append({match.captured(1).trimmed(), match.captured(2)});
    } else {
      lines.append({QString(), line.trimmed()});
    }
  }
  return lines;
}

QString ReportHtml(const QString& report) {
  QString html = QStringLiteral("<table cellspacing=\"0\" cellpadding=\"2\" width=\"100%\">");
  for (const ReportLine& line : ReportLines(report)) {
    if (line.label.isEmpty()) {
      html += QStringLiteral("<tr><td colspan=\"2\">%1</td></tr>").arg(line.value.toHtmlEscaped());
    } else {
      html += QStringLiteral("<tr><td valign=\"top\" width=\"150\"><b>%1</b></td>"
                             "<td valign=\"top\">%2</td></tr>")
                  .arg(line.label.toHtmlEscaped(), line.value.toHtmlEscaped());
    }
  }
  return html + QStringLiteral("</table>");
}

}  // namespace scanbench
