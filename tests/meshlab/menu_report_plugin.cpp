#include "menu_report_plugin.h"

#include <QApplication>
#include <QFile>
#include <QMainWindow>
#include <QMenu>
#include <QMenuBar>
#include <QTextStream>
#include <QTimer>

namespace {

// Every entry of a menu and its submenus, one "Submenu/Entry" per line.
void list_menu(const QMenu& menu, const QString& path, QTextStream& out) {
    for (QAction* action : menu.actions()) {
        if (action->isSeparator()) continue;
        const QString entry = path + action->text().remove('&');
        if (action->menu() != nullptr) list_menu(*action->menu(), entry + "/", out);
        else out << entry << "\n";
    }
}

// Polls until MeshLab's main window shows its Filters menu, then writes it to `path`.
void report_filters_menu_when_ready(const QString& path, int attempts_left) {
    QTimer::singleShot(500, [path, attempts_left] {
        for (QWidget* widget : QApplication::topLevelWidgets()) {
            auto* window = qobject_cast<QMainWindow*>(widget);
            if (window == nullptr || !window->isVisible()) continue;
            for (QAction* action : window->menuBar()->actions()) {
                if (action->menu() == nullptr || action->text().remove('&') != "Filters") continue;
                QFile file(path);
                if (!file.open(QIODevice::WriteOnly | QIODevice::Truncate)) return;
                QTextStream out(&file);
                list_menu(*action->menu(), "Filters/", out);
                return;
            }
        }
        if (attempts_left > 0) report_filters_menu_when_ready(path, attempts_left - 1);
    });
}

}  // namespace

MenuReportPlugin::MenuReportPlugin() {
    const QString report = qEnvironmentVariable("PICOSCAN_MESHLAB_MENU_REPORT");
    if (!report.isEmpty() && qobject_cast<QApplication*>(QCoreApplication::instance()) != nullptr)
        report_filters_menu_when_ready(report, 120);
}

QString MenuReportPlugin::pluginName() const { return "PicoScanTestMenuReport"; }

MESHLAB_PLUGIN_NAME_EXPORTER(MenuReportPlugin)
