#pragma once
// The HTTP side of fragsimd: cpp-httplib converts requests to server::Request, hands them to the
// Service and sends back its Response; connections are held by server/connection_server.h. No
// route logic lives here.
#include <exception>
#include <memory>
#include <string>

#include "server/service.h"

namespace httplib {
struct Request;
struct Response;
}  // namespace httplib

namespace fragsim::server {

class ConnectionServer;

class HttpServer {
 public:
  explicit HttpServer(Service& service);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Binds the configured address; returns the port (useful with port 0). Throws on failure.
  int bind();
  // Serves until stop(); returns false if the listener failed.
  bool run();
  // From any thread.
  void stop();

 private:
  void serve(const httplib::Request& req, httplib::Response& res);
  // True: answered here (cpp-httplib's HandlerResponse::Handled).
  bool pre_route(const httplib::Request& req, httplib::Response& res);
  bool on_error(const httplib::Request& req, httplib::Response& res);
  void on_exception(const httplib::Request& req, httplib::Response& res, std::exception_ptr ep);

  Service& service_;
  std::unique_ptr<ConnectionServer> server_;
};

}  // namespace fragsim::server
