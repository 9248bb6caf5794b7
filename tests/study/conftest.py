def pytest_configure(config):
    config.addinivalue_line("markers", "browser: drives the served page in headless Chromium (runs in CI)")
