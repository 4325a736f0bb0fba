#include "menu_report_plugin.h"

#include <QApplication>
#include <QCheckBox>
#include <QFile>
#include <QFileDialog>
#include <QLineEdit>
#include <QMainWindow>
#include <QMenu>
#include <QMenuBar>
#include <QPlainTextEdit>
#include <QPushButton>
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

void append_line(const QString& path, const QString& line) {
    QFile file(path);
    if (file.open(QIODevice::WriteOnly | QIODevice::Append)) QTextStream(&file) << line << "\n";
}

// The action of MeshLab's main window whose text (without '&') is `text`, once it is enabled.
QAction* main_window_action(const QString& text) {
    for (QWidget* widget : QApplication::topLevelWidgets()) {
        auto* window = qobject_cast<QMainWindow*>(widget);
        if (window == nullptr || !window->isVisible()) continue;
        for (QAction* action : window->findChildren<QAction*>())
            if (action->text().remove('&') == text && action->isEnabled()) return action;
    }
    return nullptr;
}

// Answers the modal dialogs of File > Export Mesh As as a user would: the file dialog gets `path`;
// the PLY options dialog is written to `report` as it opened (each check_iom_* box: name,
// enabled, checked), the boxes named in `untick` are unticked, and OK is pressed.
void answer_export_dialogs(const QString& path, const QString& report, const QStringList& untick) {
    QTimer::singleShot(200, [=] {
        QWidget* modal = QApplication::activeModalWidget();
        if (auto* files = qobject_cast<QFileDialog*>(modal)) {
            // Typed into the name box, as a user does (selectFile can lose to the dialog's own
            // selection while it still lists the folder).
            files->findChild<QLineEdit*>("fileNameEdit")->setText(path);
            static_cast<QDialog*>(files)->accept();  // QFileDialog::accept, through the public base
        } else if (modal != nullptr && modal->findChild<QCheckBox*>("check_iom_vertnormal") != nullptr) {
            for (QCheckBox* box : modal->findChildren<QCheckBox*>())
                if (box->objectName().startsWith("check_iom_"))
                    append_line(report, QString("%1 enabled %2 checked %3")
                                            .arg(box->objectName())
                                            .arg(int(box->isEnabled()))
                                            .arg(int(box->isChecked())));
            for (const QString& name : untick)
                if (QCheckBox* box = modal->findChild<QCheckBox*>(name)) box->setChecked(false);
            modal->findChild<QPushButton*>("okButton")->click();
            return;  // the save runs once OK returns
        }
        answer_export_dialogs(path, report, untick);
    });
}

// Whether MeshLab's log panel (the layer dialog's logPlainTextEdit) shows `text`.
bool meshlab_log_shows(const QString& text) {
    for (QWidget* widget : QApplication::topLevelWidgets())
        for (QPlainTextEdit* log : widget->findChildren<QPlainTextEdit*>("logPlainTextEdit"))
            if (log->toPlainText().contains(text)) return true;
    return false;
}

// Once MeshLab has opened the files of its command line (its log says so: the layer is filled
// while MeshLab's progress bar runs the event loop), runs File > Export Mesh As on the current
// layer and writes "exported" to `report` when MeshLab's save has returned.
void export_current_layer_when_ready(const QString& path, const QString& report, const QStringList& untick,
                                     int attempts_left) {
    QTimer::singleShot(500, [=] {
        QAction* export_as = meshlab_log_shows("All files opened") ? main_window_action("Export Mesh As...") : nullptr;
        if (export_as == nullptr) {
            if (attempts_left > 0) export_current_layer_when_ready(path, report, untick, attempts_left - 1);
            return;
        }
        answer_export_dialogs(path, report, untick);
        export_as->trigger();  // returns when MeshLab has saved (its dialogs run their own event loops)
        append_line(report, "exported");
    });
}

}  // namespace

MenuReportPlugin::MenuReportPlugin() {
    if (qobject_cast<QApplication*>(QCoreApplication::instance()) == nullptr) return;
    const QString report = qEnvironmentVariable("PICOSCAN_MESHLAB_MENU_REPORT");
    if (!report.isEmpty()) report_filters_menu_when_ready(report, 120);
    const QString export_path = qEnvironmentVariable("PICOSCAN_MESHLAB_EXPORT_AS");
    if (!export_path.isEmpty())
        export_current_layer_when_ready(export_path, qEnvironmentVariable("PICOSCAN_MESHLAB_EXPORT_REPORT"),
                                        qEnvironmentVariable("PICOSCAN_MESHLAB_EXPORT_UNTICK").split(',', Qt::SkipEmptyParts),
                                        120);
}

QString MenuReportPlugin::pluginName() const { return "PicoScanTestMenuReport"; }

MESHLAB_PLUGIN_NAME_EXPORTER(MenuReportPlugin)
