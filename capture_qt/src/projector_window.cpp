// The projector window, the screen list and the screen camera, through Qt 5 Widgets.
#include "picoscan/capture_qt.h"

#include "picoscan/error.h"

#include <QApplication>
#include <QElapsedTimer>
#include <QEventLoop>
#include <QImage>
#include <QPainter>
#include <QPixmap>
#include <QScreen>
#include <QTimer>
#include <QWidget>
#include <QWindow>

#include <opencv2/imgproc.hpp>

#include <cstdlib>

namespace picoscan {

namespace {

std::string size_text(cv::Size size) { return std::to_string(size.width) + "x" + std::to_string(size.height); }

// Starts the Qt application once. Qt aborts the process when it cannot reach a display, so
// the absence of one is checked first and reported as an Error.
void ensure_application() {
    if (QApplication::instance()) return;
    const char* display = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    const char* platform = std::getenv("QT_QPA_PLATFORM");
    if ((!display || !*display) && (!wayland || !*wayland) && (!platform || !*platform))
        throw Error("display", "no display to connect to (DISPLAY is not set); the projector window needs one");
    // Pattern pixels must map 1:1 to projector pixels, whatever the desktop's scaling.
    QApplication::setAttribute(Qt::AA_DisableHighDpiScaling);
    static int argc = 1;
    static char name[] = "picoscan";
    static char* argv[] = {name, nullptr};
    new QApplication(argc, argv);  // lives until the process exits
}

QScreen* screen_at(int index, const std::string& what) {
    ensure_application();
    const QList<QScreen*> screens = QGuiApplication::screens();
    if (index < 0 || index >= screens.size())
        throw Error(what, "screen " + std::to_string(index) + " does not exist (there " +
                              (screens.size() == 1 ? std::string("is 1 screen") : "are " + std::to_string(screens.size()) + " screens") +
                              "; see 'picoscan screens')");
    return screens[index];
}

// Runs the event loop for `milliseconds` (at least once through pending events).
void run_events(double milliseconds) {
    if (milliseconds <= 0) {
        QCoreApplication::processEvents(QEventLoop::AllEvents);
        return;
    }
    QEventLoop loop;
    QTimer::singleShot(int(std::ceil(milliseconds)), Qt::PreciseTimer, &loop, &QEventLoop::quit);
    loop.exec();
}

class PatternWidget : public QWidget {
public:
    QImage image;

protected:
    void paintEvent(QPaintEvent*) override {
        QPainter painter(this);
        painter.setRenderHint(QPainter::SmoothPixmapTransform, false);
        painter.setCompositionMode(QPainter::CompositionMode_Source);
        if (image.isNull()) painter.fillRect(rect(), Qt::black);
        else painter.drawImage(0, 0, image);
    }
};

}  // namespace

std::vector<ScreenInfo> list_screens() {
    ensure_application();
    std::vector<ScreenInfo> result;
    const QList<QScreen*> screens = QGuiApplication::screens();
    for (int index = 0; index < screens.size(); ++index) {
        const QRect geometry = screens[index]->geometry();
        result.push_back({index, screens[index]->name().toStdString(),
                          cv::Rect(geometry.x(), geometry.y(), geometry.width(), geometry.height())});
    }
    return result;
}

// ---- ProjectorWindow -----------------------------------------------------------------------

struct ProjectorWindow::Impl {
    PatternWidget widget;
    cv::Size size;
    cv::Mat painted;

    void paint(const QImage& image, const cv::Mat& pattern) {
        widget.image = image;
        widget.repaint();         // synchronous paint and flush to the window system
        QGuiApplication::sync();  // ... and the server has drawn it
        painted = pattern;
    }
};

ProjectorWindow::ProjectorWindow(int screen_index) : impl_(nullptr) {
    QScreen* screen = screen_at(screen_index, "--projector-screen");
    impl_ = std::make_unique<Impl>();
    const QRect geometry = screen->geometry();
    impl_->size = cv::Size(geometry.width(), geometry.height());
    impl_->painted = cv::Mat::zeros(impl_->size, CV_8U);
    QWidget& widget = impl_->widget;
    widget.setWindowFlags(Qt::Window | Qt::FramelessWindowHint | Qt::WindowStaysOnTopHint);
    widget.setAttribute(Qt::WA_OpaquePaintEvent);
    widget.setAttribute(Qt::WA_NoSystemBackground);
    widget.setCursor(Qt::BlankCursor);
    widget.setWindowTitle("PicoScan projector");
    widget.winId();  // creates the native window, so that it can be put on the screen
    widget.windowHandle()->setScreen(screen);
    widget.setGeometry(geometry);
    widget.showFullScreen();
    QElapsedTimer timer;
    timer.start();
    while (!widget.windowHandle()->isExposed() && timer.elapsed() < 3000) run_events(5);
    if (!widget.windowHandle()->isExposed())
        throw Error("--projector-screen", "the projector window did not appear on screen " + std::to_string(screen_index));
    impl_->paint(QImage(), impl_->painted);
}

ProjectorWindow::~ProjectorWindow() = default;

cv::Size ProjectorWindow::size() const { return impl_->size; }

void ProjectorWindow::show(const cv::Mat& pattern) {
    if (pattern.size() != impl_->size || pattern.type() != CV_8U)
        throw Error("projector window", "pattern must be 8-bit grey " + size_text(impl_->size) + " (the screen's size)");
    const cv::Mat copy = pattern.clone();
    QImage image(copy.data, copy.cols, copy.rows, int(copy.step), QImage::Format_Grayscale8);
    image = image.copy();  // owns its pixels
    impl_->paint(image, copy);
}

cv::Mat ProjectorWindow::visible() const { return impl_->painted; }

void ProjectorWindow::wait(double milliseconds) { run_events(milliseconds); }

// ---- ScreenCamera --------------------------------------------------------------------------

ScreenCamera::ScreenCamera(int screen_index) : screen_index_(screen_index) { screen_at(screen_index, "screen camera"); }

ScreenCamera::~ScreenCamera() = default;

std::string ScreenCamera::name() const { return "screen camera " + std::to_string(screen_index_); }

cv::Mat ScreenCamera::grab() {
    QScreen* screen = screen_at(screen_index_, name());
    const QImage image = screen->grabWindow(0).toImage().convertToFormat(QImage::Format_RGB888);
    if (image.isNull()) throw Error(name(), "could not grab the screen");
    const cv::Mat rgb(image.height(), image.width(), CV_8UC3, const_cast<uchar*>(image.constBits()),
                      size_t(image.bytesPerLine()));
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    return bgr;
}

}  // namespace picoscan
