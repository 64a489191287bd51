#pragma once
// The HTTP side of fragsimd: cpp-httplib converts requests to server::Request, hands them to the
// Service and sends back its Response; connections are held by server/connection_server.h. No
// route logic lives here.
#include <memory>
#include <string>

#include "server/service.h"

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
  Service& service_;
  std::unique_ptr<ConnectionServer> server_;
};

}  // namespace fragsim::server
