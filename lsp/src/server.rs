//! The server loop: one thread, messages handled in order. Documents are analysed after a
//! change once no other message is waiting (a burst of keystrokes is analysed once), and before
//! any request that reads them.

use crate::analysis::{Analysis, Context};
use crate::scenes::{self, Scenes};
use crate::{code_actions, completion, hover, navigate, stdlib_files, uri};
use lsp_server::{Connection, ErrorCode, Message, Notification, ProtocolError, Request, RequestId, Response};
use lsp_types::notification::{
    DidChangeTextDocument, DidChangeWatchedFiles, DidCloseTextDocument, DidOpenTextDocument, DidSaveTextDocument,
    Notification as _, PublishDiagnostics,
};
use lsp_types::request::{CodeActionRequest, Completion, GotoDefinition, HoverRequest, References, Request as _};
use lsp_types::{
    CodeActionProviderCapability, CompletionOptions, HoverProviderCapability, InitializeParams, OneOf,
    PublishDiagnosticsParams, SaveOptions, ServerCapabilities, TextDocumentSyncCapability, TextDocumentSyncKind,
    TextDocumentSyncOptions, TextDocumentSyncSaveOptions, Uri,
};
use std::collections::{BTreeMap, BTreeSet};
use std::panic::AssertUnwindSafe;
use std::path::PathBuf;

/// Runs the server on standard input and output until the client says `exit`.
pub fn run_stdio() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let (connection, io_threads) = Connection::stdio();
    serve(&connection)?;
    drop(connection);
    io_threads.join()?;
    Ok(())
}

/// What the server offers (full-document sync; diagnostics are pushed).
pub fn capabilities() -> ServerCapabilities {
    ServerCapabilities {
        text_document_sync: Some(TextDocumentSyncCapability::Options(TextDocumentSyncOptions {
            open_close: Some(true),
            change: Some(TextDocumentSyncKind::FULL),
            save: Some(TextDocumentSyncSaveOptions::SaveOptions(SaveOptions { include_text: Some(false) })),
            ..TextDocumentSyncOptions::default()
        })),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec![".".into(), "[".into(), ":".into()]),
            ..CompletionOptions::default()
        }),
        definition_provider: Some(OneOf::Left(true)),
        references_provider: Some(OneOf::Left(true)),
        code_action_provider: Some(CodeActionProviderCapability::Simple(true)),
        ..ServerCapabilities::default()
    }
}

/// Initializes over `connection`, then serves until `shutdown` and `exit`.
pub fn serve(connection: &Connection) -> Result<(), ProtocolError> {
    let info = serde_json::json!({
        "capabilities": capabilities(),
        "serverInfo": { "name": "vrsc", "version": env!("CARGO_PKG_VERSION") },
    });
    let (id, params) = connection.initialize_start()?;
    connection.initialize_finish(id, info)?;
    let params: InitializeParams = serde_json::from_value(params).unwrap_or_default();
    let mut server = Server::new(workspace_roots(&params));
    while let Ok(message) = connection.receiver.recv() {
        match message {
            Message::Request(request) => {
                if connection.handle_shutdown(&request)? {
                    return Ok(());
                }
                let id = request.id.clone();
                // A bug in a feature fails its request, not the session.
                let response = std::panic::catch_unwind(AssertUnwindSafe(|| server.request(request, connection)))
                    .unwrap_or_else(|_| {
                        Response::new_err(id, ErrorCode::InternalError as i32, "internal error in vrsc lsp".into())
                    });
                send(connection, response.into());
            }
            Message::Notification(notification) => server.notification(notification),
            Message::Response(_) => {}
        }
        if connection.receiver.is_empty() {
            server.analyse_pending(connection);
        }
    }
    Ok(())
}

fn send(connection: &Connection, message: Message) {
    // The client has gone when sending fails; the loop then ends on the closed receiver.
    let _ = connection.sender.send(message);
}

/// The folders of the workspace: its folders, else its root URI.
#[allow(deprecated)] // `root_uri` is still what many clients send.
fn workspace_roots(params: &InitializeParams) -> Vec<PathBuf> {
    let folders = params.workspace_folders.iter().flatten().filter_map(|f| uri::to_path(&f.uri));
    let mut roots: Vec<PathBuf> = folders.collect();
    if roots.is_empty() {
        roots.extend(params.root_uri.as_ref().and_then(uri::to_path));
    }
    roots
}

/// An open document.
struct Document {
    text: String,
    /// Canonical path, for a file.
    path: Option<PathBuf>,
    analysis: Option<Analysis>,
}

struct Server {
    documents: BTreeMap<Uri, Document>,
    /// Documents changed since their last analysis (or reading a file that changed).
    pending: BTreeSet<Uri>,
    /// Documents closed since diagnostics were last published.
    closed: Vec<Uri>,
    scenes: Scenes,
}

impl Server {
    fn new(roots: Vec<PathBuf>) -> Server {
        Server { documents: BTreeMap::new(), pending: BTreeSet::new(), closed: Vec::new(), scenes: Scenes::new(roots) }
    }

    fn notification(&mut self, n: Notification) {
        match n.method.as_str() {
            DidOpenTextDocument::METHOD => {
                let Ok(params) = n.extract::<lsp_types::DidOpenTextDocumentParams>(DidOpenTextDocument::METHOD) else {
                    return;
                };
                let doc = params.text_document;
                let path = uri::to_path(&doc.uri).map(|p| scenes::canonical(&p));
                self.documents.insert(doc.uri.clone(), Document { text: doc.text, path, analysis: None });
                self.pending.insert(doc.uri);
            }
            DidChangeTextDocument::METHOD => {
                let Ok(params) = n.extract::<lsp_types::DidChangeTextDocumentParams>(DidChangeTextDocument::METHOD)
                else {
                    return;
                };
                let uri = params.text_document.uri;
                // Full sync: the last change holds the whole text.
                if let (Some(doc), Some(change)) =
                    (self.documents.get_mut(&uri), params.content_changes.into_iter().last())
                {
                    doc.text = change.text;
                    let path = doc.path.clone();
                    self.pending.insert(uri);
                    self.mark_dependents(path.as_deref());
                }
            }
            DidSaveTextDocument::METHOD => {
                // A saved scene may list other modules now: every open module is analysed again.
                if let Ok(params) = n.extract::<lsp_types::DidSaveTextDocumentParams>(DidSaveTextDocument::METHOD)
                    && params.text_document.uri.as_str().ends_with(".toml")
                {
                    self.scenes.rescan();
                    self.pending.extend(self.documents.keys().cloned());
                }
            }
            DidChangeWatchedFiles::METHOD => {
                // A scene file was created, changed or deleted (the editor watches `*.toml`).
                self.scenes.rescan();
                self.pending.extend(self.documents.keys().cloned());
            }
            DidCloseTextDocument::METHOD => {
                if let Ok(params) = n.extract::<lsp_types::DidCloseTextDocumentParams>(DidCloseTextDocument::METHOD) {
                    let uri = params.text_document.uri;
                    // The file on disk counts again for the documents that read it.
                    let path = self.documents.remove(&uri).and_then(|d| d.path);
                    self.pending.remove(&uri);
                    self.mark_dependents(path.as_deref());
                    self.closed.push(uri);
                }
            }
            _ => {}
        }
    }

    /// Marks for analysis every open document whose last analysis read the file at `path`.
    fn mark_dependents(&mut self, path: Option<&std::path::Path>) {
        let Some(path) = path else { return };
        for (uri, doc) in &self.documents {
            if doc.analysis.as_ref().is_some_and(|a| a.path.as_deref() != Some(path) && a.depends_on(path)) {
                self.pending.insert(uri.clone());
            }
        }
    }

    /// Analyses every changed document and publishes its diagnostics; clears those of closed
    /// documents.
    fn analyse_pending(&mut self, connection: &Connection) {
        for uri in std::mem::take(&mut self.closed) {
            let params = PublishDiagnosticsParams { uri, diagnostics: Vec::new(), version: None };
            send(connection, Notification::new(PublishDiagnostics::METHOD.to_string(), params).into());
        }
        for uri in std::mem::take(&mut self.pending) {
            self.analyse(&uri);
            let Some(analysis) = self.documents.get(&uri).and_then(|d| d.analysis.as_ref()) else { continue };
            // A standard module opened from its cached copy is the compiler's own: no diagnostics.
            let is_std = analysis.path.as_deref().is_some_and(|p| stdlib_files::module_of(p).is_some());
            let diagnostics =
                if is_std { Vec::new() } else { analysis.diagnostics.iter().map(|r| r.diagnostic.clone()).collect() };
            let params = PublishDiagnosticsParams { uri: uri.clone(), diagnostics, version: None };
            send(connection, Notification::new(PublishDiagnostics::METHOD.to_string(), params).into());
        }
    }

    fn analyse(&mut self, uri: &Uri) {
        let overlay: Vec<(PathBuf, String)> =
            self.documents.values().filter_map(|d| Some((d.path.clone()?, d.text.clone()))).collect();
        let Some(doc) = self.documents.get_mut(uri) else { return };
        if !is_module(uri) {
            return;
        }
        let scenes = doc.path.as_deref().map(|p| self.scenes.listing(p)).unwrap_or_default();
        let context = Context { path: doc.path.clone(), scenes, overlay };
        // A compiler bug on this text leaves the document without analysis rather than ending the
        // session.
        let analysed =
            std::panic::catch_unwind(AssertUnwindSafe(|| Analysis::new(uri.clone(), doc.text.clone(), context)));
        doc.analysis = analysed.ok();
    }

    /// The analysis of `uri`, brought up to date first.
    fn analysis(&mut self, uri: &Uri, connection: &Connection) -> Option<&Analysis> {
        if self.pending.contains(uri) {
            self.analyse_pending(connection);
        }
        self.documents.get(uri)?.analysis.as_ref()
    }

    fn request(&mut self, request: Request, connection: &Connection) -> Response {
        let id = request.id.clone();
        match request.method.as_str() {
            HoverRequest::METHOD => self.with::<HoverRequest>(request, connection, |a, p| {
                hover::hover(a, p.text_document_position_params.position)
            }),
            Completion::METHOD => self.with::<Completion>(request, connection, |a, p| {
                Some(lsp_types::CompletionResponse::Array(completion::complete(a, p.text_document_position.position)))
            }),
            GotoDefinition::METHOD => self.with::<GotoDefinition>(request, connection, |a, p| {
                let found = navigate::definition(a, p.text_document_position_params.position);
                (!found.is_empty()).then_some(lsp_types::GotoDefinitionResponse::Array(found))
            }),
            References::METHOD => self.with::<References>(request, connection, |a, p| {
                let found = navigate::references(a, p.text_document_position.position, p.context.include_declaration);
                Some(found)
            }),
            CodeActionRequest::METHOD => {
                self.with::<CodeActionRequest>(request, connection, |a, p| Some(code_actions::actions(a, p.range)))
            }
            method => Response::new_err(id.clone(), ErrorCode::MethodNotFound as i32, format!("no method `{method}`")),
        }
    }

    /// Runs `handle` on the analysis of the request's document: `null` for a document the
    /// server has not seen; an `InvalidParams` error for parameters that do not parse.
    fn with<R>(
        &mut self,
        request: Request,
        connection: &Connection,
        handle: impl FnOnce(&Analysis, &R::Params) -> R::Result,
    ) -> Response
    where
        R: lsp_types::request::Request,
        R::Params: DocumentParams,
    {
        let id: RequestId = request.id.clone();
        let params: R::Params = match request.extract(R::METHOD) {
            Ok((_, params)) => params,
            Err(e) => return Response::new_err(id, ErrorCode::InvalidParams as i32, format!("{e:?}")),
        };
        let uri = params.document().clone();
        let result = self.analysis(&uri, connection).map(|a| handle(a, &params));
        Response::new_ok(id, result)
    }
}

/// Whether a document is a VRS module (scene TOML files are read from disk, not analysed).
fn is_module(uri: &Uri) -> bool {
    !uri.as_str().ends_with(".toml")
}

/// Requests about one document.
trait DocumentParams {
    fn document(&self) -> &Uri;
}

impl DocumentParams for lsp_types::HoverParams {
    fn document(&self) -> &Uri {
        &self.text_document_position_params.text_document.uri
    }
}

impl DocumentParams for lsp_types::CompletionParams {
    fn document(&self) -> &Uri {
        &self.text_document_position.text_document.uri
    }
}

impl DocumentParams for lsp_types::GotoDefinitionParams {
    fn document(&self) -> &Uri {
        &self.text_document_position_params.text_document.uri
    }
}

impl DocumentParams for lsp_types::ReferenceParams {
    fn document(&self) -> &Uri {
        &self.text_document_position.text_document.uri
    }
}

impl DocumentParams for lsp_types::CodeActionParams {
    fn document(&self) -> &Uri {
        &self.text_document.uri
    }
}
